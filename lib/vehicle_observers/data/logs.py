"""Drive-log CSV schema and a validated loader.

Schema (units in the column names; one header line; comma separated; ``.csv`` or
``.csv.gz``):

========================  ========  =====================================================
column                    required  meaning
========================  ========  =====================================================
``t_s``                   yes       time [s], strictly increasing
``vx_mps``                yes       longitudinal speed [m/s], > 0 where a model divides by it
``delta_roadwheel_rad``   yes       road-wheel steering angle [rad], left positive
``yaw_rate_radps``        yes       yaw rate [rad/s], left positive
``ay_mps2``               no        lateral acceleration at the CG [m/s^2]
``vy_mps``                no        reference lateral velocity [m/s] (INS, Correvit, truth)
``yL_m``                  no        vision lateral offset at look-ahead [m]
``psiL_rad``              no        vision relative heading [rad]
``Ff_N``, ``Fr_N``        no        front / rear axle lateral force [N] (truth, emulated)
``rho_1pm``               no        road curvature [1/m] (truth, emulated)
========================  ========  =====================================================

Any other numeric column is kept in :attr:`DriveLog.extra`; a column named
``<quantity>_<unit>`` with a unit of :data:`UNIT_RANGES` (``ax_mps2``, ``beta_rad``, ...) may
be read by any estimator that declares it, and :func:`check_plausible` checks it against its
unit's range like the schema's columns. Bad input raises
:class:`~vehicle_observers.core.errors.LogFormatError` naming the file, column and row (rows are
counted as data rows from 0; the file line is that + 2) and what was expected; the file is
never modified.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import os
import re
import secrets
import socket
import stat
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehicle_observers.core.errors import LogFormatError

REQUIRED = ("t_s", "vx_mps", "delta_roadwheel_rad", "yaw_rate_radps")
OPTIONAL = ("ay_mps2", "vy_mps", "yL_m", "psiL_rad", "Ff_N", "Fr_N", "rho_1pm")
_ATTR = {"t_s": "t", "vx_mps": "vx", "delta_roadwheel_rad": "delta",
         "yaw_rate_radps": "yaw_rate", "ay_mps2": "ay", "vy_mps": "vy", "yL_m": "yL",
         "psiL_rad": "psiL", "Ff_N": "Ff", "Fr_N": "Fr", "rho_1pm": "rho"}


@dataclass
class DriveLog:
    """One drive, arrays of shape (N,). Optional channels are ``None`` when absent."""

    t: np.ndarray
    vx: np.ndarray
    delta: np.ndarray
    yaw_rate: np.ndarray
    ay: np.ndarray | None = None
    vy: np.ndarray | None = None
    yL: np.ndarray | None = None
    psiL: np.ndarray | None = None
    Ff: np.ndarray | None = None
    Fr: np.ndarray | None = None
    rho: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = ""

    def __post_init__(self):
        """Convert and refuse a log no consumer can use, naming the column and row
        (:mod:`vehicle_observers.core.inputs`): lists, pandas and polars Series become float
        arrays, a ``datetime64`` / ``timedelta64`` time seconds from the first sample;
        ``t`` must be strictly increasing; every schema channel a 1-D array of finite
        numbers of the length of ``t`` (a NaN from a notebook would otherwise surface as a
        NaN estimate or a solver error far from its cause); ``extra`` columns must have
        that length (they may hold NaN: truth channels that are not measured everywhere)."""
        self.validate()

    def validate(self):
        """The checks of construction, again (a log whose arrays were replaced since, e.g.
        two timestamps swapped, is refused where it enters the registry)."""
        from vehicle_observers.core.inputs import as_array, as_time

        name = self.source or "DriveLog"
        n = None
        for c, a in _ATTR.items():
            v = getattr(self, a)
            if v is None:          # absent (an estimate read back has no steering, ...)
                continue
            v = as_time(v, f"column {c!r}", name, LogFormatError) if a == "t" else \
                as_array(v, f"column {c!r}", name, error=LogFormatError)
            if n is None:
                n = len(v)
            elif len(v) != n:
                raise LogFormatError(f"{name}: column {c!r} has {len(v)} rows, 't_s' has {n}")
            if v is not getattr(self, a):
                setattr(self, a, v)
        for c, v in list(self.extra.items()):
            v = as_array(v, f"extra column {c!r}", name, ndim=None, allow_nan=True,
                         error=LogFormatError)
            if v.ndim != 1 or len(v) != n:
                raise LogFormatError(f"{name}: extra column {c!r} has shape {np.shape(v)}, "
                                     f"expected ({n},)")
            self.extra[c] = v
        return self

    @classmethod
    def from_frame(cls, frame, source: str = "") -> "DriveLog":
        """A log from a pandas or polars DataFrame (or a mapping) of schema columns
        (``t_s``, ``vx_mps``, ...; :data:`REQUIRED`, :data:`OPTIONAL`); other numeric
        columns go to ``extra``. A missing required column or a column of text is refused
        naming it."""
        from vehicle_observers.core.inputs import frame_columns

        cols = frame_columns(frame)
        where = source or type(frame).__name__
        missing = [c for c in REQUIRED if c not in cols]
        if missing:
            raise LogFormatError(f"{where}: missing column(s) {', '.join(map(repr, missing))} "
                                 f"(columns: {', '.join(map(str, cols))})")
        kw = {_ATTR[c]: v for c, v in cols.items() if c in _ATTR}
        extra = {c: v for c, v in cols.items() if c not in _ATTR}
        return cls(**kw, extra=extra, source=where)

    def __len__(self):
        return len(self.t)

    @property
    def dt(self) -> float:
        """Median sample period [s]."""
        return float(np.median(np.diff(self.t)))

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def has(self, column: str) -> bool:
        attr = _ATTR.get(column)
        return (getattr(self, attr) is not None) if attr else column in self.extra

    def require(self, *columns: str, purpose: str = ""):
        """Raise LogFormatError naming the first missing column (e.g. for an observer)."""
        for c in columns:
            if not self.has(c):
                why = f" ({purpose} needs it)" if purpose else ""
                raise LogFormatError(f"{self.source or 'log'}: missing column {c!r}{why}")

    def columns(self) -> dict[str, np.ndarray]:
        out = {c: getattr(self, a) for c, a in _ATTR.items() if getattr(self, a) is not None}
        out.update(self.extra)
        return out

    def segment(self, t0: float, t1: float) -> "DriveLog":
        """Samples with ``t0 <= t <= t1`` (a copy)."""
        k = (self.t >= t0) & (self.t <= t1)
        if not k.any():
            raise ValueError(f"no samples in [{t0}, {t1}] (log spans {self.t[0]}..{self.t[-1]} s)")
        kw = {a: (None if getattr(self, a) is None else getattr(self, a)[k].copy())
              for a in _ATTR.values()}
        return DriveLog(**kw, extra={c: v[k].copy() for c, v in self.extra.items()},
                        source=f"{self.source}[{t0:g}..{t1:g} s]")

    def to_csv(self, path):
        """Write in the schema; atomic (a temporary file renamed into place)."""
        write_csv(path, self.columns())


def as_log(obj, source: str = "") -> DriveLog:
    """The :class:`DriveLog` of a public entry's ``log`` argument: a DriveLog checked again
    (:meth:`DriveLog.validate`), or a pandas / polars DataFrame or a mapping of schema
    columns (:meth:`DriveLog.from_frame`); anything else refused naming its type."""
    from vehicle_observers.core.inputs import is_frame

    if isinstance(obj, DriveLog):
        try:
            return obj.validate()
        except LogFormatError as exc:
            raise LogFormatError(f"{source}: {exc}" if source else str(exc)) from None
    if is_frame(obj) or isinstance(obj, dict):
        return DriveLog.from_frame(obj, source)
    raise LogFormatError(f"{source or 'log'}: expected a DriveLog, or a pandas / polars "
                         f"DataFrame of schema columns, got {type(obj).__name__}")


#: rows per batch when writing (the progress callback is called after each)
WRITE_BATCH = 1 << 20
#: longest field accepted in a log [characters] (a longer one is not a number of a log)
MAX_FIELD = 128 * 1024


# ------------------------------------------------------------------ outputs ---------------
# Every file a command writes goes through :func:`check_output` (before any computing) and
# :class:`AtomicOutput` (written to a hidden partial file, renamed into place when complete).


class OutputError(ValueError):
    """An output path that cannot be used: it is an input of the same command (whatever the
    spelling), a folder or special file, in a missing folder, or its suffix names a format
    that is not written. The message names the option and the reason."""


def cache_dir() -> Path:
    """Folder of the package's per-user state (ML-tuning and design caches, records of the
    partial files being written): ``$VEHICLE_OBSERVERS_CACHE`` or
    ``$XDG_CACHE_HOME/vehicle_observers`` (default ``~/.cache/vehicle_observers``)."""
    d = os.environ.get("VEHICLE_OBSERVERS_CACHE")
    if d:
        return Path(d)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "vehicle_observers"


#: suffixes of the CSV outputs (compared in lower case); the format follows the suffix:
#: ``.csv.gz`` is written gzip-compressed
CSV_SUFFIXES = (".csv", ".csv.gz")
#: compression suffixes that are recognised but not written (refused naming them)
OTHER_COMPRESSION = (".bz2", ".xz", ".lzma", ".zip", ".zst", ".lz4", ".7z", ".br", ".z")
#: gzip level of ``.gz`` outputs (1: about 3x smaller than the text at the speed of the disk)
GZIP_LEVEL = 1


def output_suffix(path, suffixes=CSV_SUFFIXES, option: str = "--out") -> str:
    """The suffix of ``path`` among ``suffixes`` (the longest that matches, case-insensitive);
    raises :class:`OutputError` naming the suffix otherwise (a ``.xz`` or ``.txt`` name would
    get content of another format)."""
    name = Path(path).name.lower()
    for s in sorted(suffixes, key=len, reverse=True):
        if name.endswith(s) and len(name) > len(s):
            return s
    comp = next((c for c in OTHER_COMPRESSION if name.endswith(c)), None)
    ext = "".join(Path(name).suffixes[-2:])
    why = (f"{comp} compression is not written" if comp else
           f"the suffix {ext!r} names no format written here" if ext else "the name has no suffix")
    raise OutputError(f"{option} {path}: {why}; expected a name ending in "
                      f"{' or '.join(suffixes)} (the format follows the suffix)")


_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def special_file(path) -> str | None:
    """What ``path`` is when it exists and is not a regular file (symlinks followed), e.g.
    ``"a FIFO (named pipe)"``; ``None`` for a regular file or a missing path. Reading a FIFO
    without a writer blocks forever and a device never ends: such inputs are refused."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def same_file(a, b) -> bool:
    """``a`` and ``b`` are one file (same device and inode: symlinks, hard links, relative and
    absolute spellings, ``/proc/self/fd/N``); False when either does not exist."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def check_output(path, inputs=None, suffixes=CSV_SUFFIXES, option: str = "--out") -> Path:
    """Validate an output path before any computing; returns it as a :class:`Path`.

    ``inputs``: ``{description: path}`` of the command's inputs (e.g. ``{"the input log":
    log, "the vehicle file": vehicle_path}``); ``None`` values are skipped. Refused with
    :class:`OutputError`: an output that is one of the inputs (:func:`same_file`), a folder
    or special file (:func:`special_file`), in a folder that does not exist, or whose suffix
    is not in ``suffixes`` (:func:`output_suffix`). Every command that writes (``estimate``,
    ``identify``, and any later one writing several files) calls this for each output with
    all its inputs.
    """
    raw = str(path)
    if not raw.strip():
        raise OutputError(f"{option}: empty path")
    out = Path(raw)
    for what, inp in (inputs or {}).items():
        if inp is not None and same_file(out, inp):
            raise OutputError(f"{option} {raw}: is {what} ({inp}); writing there would destroy "
                              "it: choose another file")
    kind = special_file(out)
    if kind is not None:
        raise OutputError(f"{option} {raw}: is {kind}, expected the path of a regular file to "
                          "write")
    folder = out.parent
    if not folder.exists():
        raise OutputError(f"{option} {raw}: folder {folder} does not exist")
    if not folder.is_dir():
        raise OutputError(f"{option} {raw}: {folder} is not a folder")
    output_suffix(out, suffixes, option)
    return out


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


#: name of a partial file: hidden, with the writer's pid and a random token (a user's file
#: cannot collide with it by accident; a killed run's files are found by their records)
_PARTIAL_RE = re.compile(r"\..+\.(\d+)-([0-9a-f]{16})\.partial")


def partials_registry() -> Path:
    """Folder of the records of partial files being written (:func:`cache_dir` /
    ``partials``): one JSON file per partial file with its path, device, inode and writer."""
    return cache_dir() / "partials"


def _record_partial(tmp: Path, token: str, st) -> Path | None:
    """Write the record of a partial file just created; ``None`` if the registry cannot be
    written (the file is then never removed by a later run, only by this one)."""
    rec = {"partial": str(tmp.resolve()), "pid": os.getpid(), "host": socket.gethostname(),
           "dev": st.st_dev, "ino": st.st_ino}
    try:
        reg = partials_registry()
        reg.mkdir(parents=True, exist_ok=True)
        m = reg / f"{token}.json"
        m.write_text(json.dumps(rec))
        return m
    except OSError:
        return None


def remove_stale_partials() -> list[Path]:
    """Delete the partial files of runs that were killed (SIGKILL, power loss): only files
    that this program recorded (:func:`partials_registry`), whose writer process is gone, and
    that are still the file recorded (same device and inode, a regular file with a partial
    file's name); a user's file is never touched. Returns the files removed."""
    gone = []
    try:
        records = sorted(partials_registry().glob("*.json"))
    except OSError:
        return gone
    host = socket.gethostname()
    for m in records:
        try:
            d = json.loads(m.read_text())
            pid, f, dev, ino = int(d["pid"]), Path(d["partial"]), int(d["dev"]), int(d["ino"])
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if d.get("host") != host or pid == os.getpid() or _pid_alive(pid):
            continue
        try:
            st = os.lstat(f)
            if (st.st_dev, st.st_ino) == (dev, ino) and stat.S_ISREG(st.st_mode) \
                    and _PARTIAL_RE.fullmatch(f.name):
                f.unlink()
                gone.append(f)
        except FileNotFoundError:
            pass
        except OSError:
            continue
        try:
            m.unlink()
        except OSError:
            pass
    return gone


#: partial files being written by this process, ``{partial file: its record or None}``
#: (removed by the command line's signal handler)
ACTIVE_PARTIALS: dict = {}


def discard_active_partials():
    """Remove every partial file of this process and its record (signal handlers: no
    exception is raised, errors are ignored)."""
    for p, m in list(ACTIVE_PARTIALS.items()):
        for f in (p, m):
            if f is not None:
                try:
                    os.unlink(f)
                except OSError:
                    pass
        ACTIVE_PARTIALS.pop(p, None)


class AtomicOutput:
    """An output file written completely or not at all.

    ``with AtomicOutput(path) as out: ...; out.commit(columns)`` (or ``commit_text``): on
    entry, the partial files of killed runs are removed (:func:`remove_stale_partials`) and
    this run's partial file is created at once (so an unwritable folder fails before any
    computing), next to ``path`` under a hidden name with a random token
    (``.<name>.<pid>-<token>.partial``, created exclusively: no existing file is touched) and
    recorded in :func:`partials_registry`; ``commit`` writes it and renames it onto ``path``;
    leaving the block without a commit (error, signal) deletes it. A name ending in ``.gz``
    is written gzip-compressed (``compress`` overrides). The file gets the normal
    permissions (``0666 & ~umask``).
    """

    def __init__(self, path, compress: bool | None = None):
        self.path = Path(path)
        self.token = secrets.token_hex(8)
        self.tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}-{self.token}.partial")
        self.compress = self.path.name.lower().endswith(".gz") if compress is None else compress
        self.done = False

    def __enter__(self):
        remove_stale_partials()
        fd = os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        try:
            st = os.fstat(fd)
        finally:
            os.close(fd)
        ACTIVE_PARTIALS[self.tmp] = None
        ACTIVE_PARTIALS[self.tmp] = _record_partial(self.tmp, self.token, st)
        return self

    def commit(self, columns: dict, progress=None):
        """Write ``columns`` as CSV (:func:`_write_table`) and rename into place."""
        _write_table(self.tmp, columns, progress, compress=self.compress,
                     gzip_name=self.path.name)
        self._finish()

    def commit_text(self, text: str, check=None):
        """Write ``text`` (UTF-8), call ``check(partial_path)`` (which may raise: nothing is
        written then), and rename into place."""
        data = text.encode("utf-8")
        if self.compress:
            data = gzip.compress(data, compresslevel=GZIP_LEVEL, mtime=0)
        _write_bytes(self.tmp, data)
        if check is not None:
            check(self.tmp)
        self._finish()

    def _finish(self):
        os.replace(self.tmp, self.path)
        self.done = True
        self._forget()

    def _forget(self):
        m = ACTIVE_PARTIALS.pop(self.tmp, None)
        if m is not None:
            try:
                m.unlink()
            except OSError:
                pass

    def __exit__(self, *exc):
        if not self.done:
            try:
                self.tmp.unlink(missing_ok=True)
            except OSError:
                pass
        self._forget()
        return False


def _write_bytes(path, data: bytes):
    """Write ``data`` to ``path`` (the one place small outputs are written)."""
    with open(path, "wb") as fh:
        fh.write(data)


def _write_table(path, columns: dict, progress=None, compress: bool = False,
                 gzip_name: str = ""):
    """CSV with polars' writer (header line, comma separated, shortest round-trip floats
    (Ryu), integer / boolean columns as integers), in batches of :data:`WRITE_BATCH` rows with
    ``progress(rows_written, rows)`` after each; gzip-compressed (level :data:`GZIP_LEVEL`,
    stored name ``gzip_name`` without ``.gz``) when ``compress``. polars formats floats more
    than twice as fast as pyarrow's writer."""
    import polars as pl

    names = list(columns)
    arrs = []
    for c in names:
        a = np.asarray(columns[c])
        arrs.append(a.astype(np.int8) if a.dtype == bool else a)
    n = len(arrs[0]) if arrs else 0
    for c, a in zip(names, arrs):
        if a.shape != (n,):
            raise ValueError(f"column {c!r} has shape {a.shape}, expected ({n},)")
    with open(path, "wb") as raw:
        fh = (gzip.GzipFile(filename=gzip_name, mode="wb", fileobj=raw,
                            compresslevel=GZIP_LEVEL, mtime=0) if compress else raw)
        fh.write((",".join(names) + "\n").encode())   # plain header line, never quoted
        for a in range(0, n, WRITE_BATCH):
            b = min(n, a + WRITE_BATCH)
            pl.DataFrame({c: x[a:b] for c, x in zip(names, arrs)}).write_csv(
                fh, include_header=False, quote_style="never")
            if progress is not None:
                progress(b, n)
        if compress:
            fh.close()


def write_csv(path, columns: dict[str, np.ndarray], progress=None):
    """Write named equal-length columns as CSV (polars), completely or not at all; a name
    ending in ``.gz`` is written gzip-compressed."""
    with AtomicOutput(path) as out:
        out.commit(columns, progress)


def is_gzip(path) -> bool:
    """The file starts with the gzip magic bytes (the content decides, not the name)."""
    with open(path, "rb") as fh:
        return fh.read(2) == b"\x1f\x8b"


def _open_text(path: Path):
    if is_gzip(path):
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8-sig")
    return open(path, encoding="utf-8-sig", newline="")


def _read_header(path: Path, name: str) -> list[str]:
    try:
        with _open_text(path) as fh:
            line = fh.readline(MAX_FIELD + 1)
    except (OSError, UnicodeDecodeError, EOFError, gzip.BadGzipFile) as exc:
        raise LogFormatError(f"{name}: cannot read ({exc})") from None
    if len(line) > MAX_FIELD:
        raise LogFormatError(f"{name}: header line longer than {MAX_FIELD} characters")
    if not line.strip():
        raise LogFormatError(f"{name}: empty file (expected a header line with "
                             f"{', '.join(REQUIRED)})")
    return [h.strip() for h in next(csv.reader([line]))]


def _diagnose(path: Path, name: str, header: list[str]):
    """Slow row-by-row scan, only after the fast reader failed: raise the LogFormatError that
    names the first bad row/column."""
    ncol = len(header)
    csv.field_size_limit(MAX_FIELD)
    try:
        with _open_text(path) as fh:
            reader = csv.reader(fh)
            next(reader)
            for i, row in enumerate(reader):
                if len(row) != ncol:
                    raise LogFormatError(f"{name}: row {i} (line {i + 2}) has {len(row)} "
                                         f"fields, expected {ncol}")
                for j, s in enumerate(row):
                    try:
                        float(s)
                    except ValueError:
                        raise LogFormatError(f"{name}: column {header[j]!r}, row {i} (line "
                                             f"{i + 2}): {s[:40]!r} is not a number") from None
    except csv.Error as exc:
        raise LogFormatError(f"{name}: line {reader.line_num + 1}: {exc} (a field longer "
                             f"than {MAX_FIELD} characters or a broken quote)") from None
    except (OSError, EOFError, UnicodeDecodeError, gzip.BadGzipFile) as exc:
        raise LogFormatError(f"{name}: cannot read ({exc}; truncated or corrupt file?)") from None


class _Guard(io.RawIOBase):
    """Binary reader handed to pyarrow: decompresses ``.gz``, reports ``progress(bytes of the
    file read, file size)``, and stops at the first line longer than :data:`MAX_FIELD`
    (``long_line`` = its line number) or at a read error (``error``)."""

    def __init__(self, path: Path, progress=None):
        self.raw = open(path, "rb")
        self.fh = gzip.GzipFile(fileobj=self.raw) if is_gzip(path) else self.raw
        self.size = max(path.stat().st_size, 1)
        self.progress = progress
        self.lines = 0        # newlines seen
        self.run = 0          # length of the current (unfinished) line
        self.long_line = None
        self.error = None

    def readable(self):
        return True

    def read(self, n=-1):
        if self.long_line is not None or self.error is not None:
            return b""
        try:
            b = self.fh.read(n)
        except (OSError, EOFError, zlib.error) as exc:
            self.error = exc
            return b""
        self._check(b)
        if self.progress is not None:
            self.progress(min(self.raw.tell(), self.size), self.size)
        return b if self.long_line is None else b""

    def _check(self, b):
        nl = np.flatnonzero(np.frombuffer(b, np.uint8) == 10)
        if not len(nl):
            self.run += len(b)
            if self.run > MAX_FIELD:
                self.long_line = self.lines + 1
            return
        lengths = np.r_[self.run + nl[0], np.diff(nl) - 1]
        if lengths.max() > MAX_FIELD:
            self.long_line = self.lines + 1 + int(np.argmax(lengths > MAX_FIELD))
        self.lines += len(nl)
        self.run = len(b) - 1 - int(nl[-1])
        if self.run > MAX_FIELD and self.long_line is None:
            self.long_line = self.lines + 1

    def close(self):
        self.fh.close()
        self.raw.close()
        super().close()


#: bytes per block of the CSV reader
BLOCK = 1 << 22


def _text_size(path: Path) -> int:
    """Bytes of CSV text: the file size, or for gzip the size stored in its trailer (the
    uncompressed size modulo 2^32; the compressed size when that is smaller)."""
    size = path.stat().st_size
    if size < 18 or not is_gzip(path):
        return size
    with open(path, "rb") as fh:
        fh.seek(-4, os.SEEK_END)
        isize = int.from_bytes(fh.read(4), "little")
    return max(isize, size)


def _grown(a: np.ndarray, n: int, cap: int) -> np.ndarray:
    """A (cap,) float array holding the first ``n`` values of ``a``."""
    out = np.empty(cap)
    out[:n] = a[:n]
    return out


def _read_columns(path: Path, name: str, header: list[str], keep: list[str], progress=None):
    """Numeric columns ``keep`` of the CSV with pyarrow's streaming reader, each batch copied
    at once into float64 arrays sized from the bytes read so far (peak memory: the arrays plus
    a few blocks). Returns ``{column: (N,) array}`` with NaN for empty / null fields."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    guard = _Guard(path, progress)
    total = _text_size(path)
    ropt = pacsv.ReadOptions(column_names=header, skip_rows=1, block_size=BLOCK,
                             use_threads=True)
    copt = pacsv.ConvertOptions(column_types={c: pa.float64() for c in header},
                                include_columns=keep, strings_can_be_null=False)
    buf = {c: np.empty(0) for c in keep}
    n = 0
    try:
        with pacsv.open_csv(pa.PythonFile(guard, mode="r"), read_options=ropt,
                            convert_options=copt,
                            parse_options=pacsv.ParseOptions(newlines_in_values=False)) as rd:
            for batch in rd:
                m = batch.num_rows
                if n + m > len(buf[keep[0]]):
                    # first batch ~ one block: rows of the whole text projected (+2 %)
                    cap = (int(m * total / BLOCK * 1.02) + 1 if n == 0
                           else int(1.25 * len(buf[keep[0]])))
                    buf = {c: _grown(v, n, max(cap, n + m)) for c, v in buf.items()}
                for c in keep:
                    buf[c][n:n + m] = batch.column(c).to_numpy(zero_copy_only=False)
                n += m
                del batch
    except (pa.ArrowInvalid, pa.ArrowTypeError, ValueError):
        if guard.long_line is None and guard.error is None:
            guard.close()
            _diagnose(path, name, header)
            raise LogFormatError(f"{name}: not a numeric CSV table (the fast reader rejected "
                                 "it)") from None
    except OSError as exc:
        guard.error = guard.error or exc
    guard.close()
    if guard.long_line is not None:
        raise LogFormatError(f"{name}: line {guard.long_line} is longer than {MAX_FIELD} "
                             "characters (expected one row of numbers per line)")
    if guard.error is not None:
        raise LogFormatError(f"{name}: cannot read ({guard.error}; truncated or corrupt "
                             "file?)")
    out = {c: v[:n] for c, v in buf.items()}
    pa.default_memory_pool().release_unused()   # hand the freed Arrow blocks back to the OS
    return out


def load_log(path, min_vx: float | None = 0.0, required=REQUIRED, columns=None,
             progress=None) -> DriveLog:
    """Load and validate a drive log (see module docstring for the schema).

    Read with pyarrow's multi-threaded streaming CSV reader (a UTF-8 byte-order mark is
    accepted). Parameters
    ----------
    min_vx : speed floor [m/s]; every ``vx_mps`` sample must be ``> min_vx`` (``None`` skips
        the check: the command line handles standstill rows itself).
    required : columns that must be present.
    columns : read only these columns (plus ``required``; ``None``: all); keeps the memory
        of a large log near the arrays actually used.
    progress : ``progress(bytes_read, bytes_total)`` called while reading.
    """
    path = Path(path)
    name = path.name
    if not path.exists():
        raise LogFormatError(f"{path}: no such file")
    kind = special_file(path)
    if kind is not None:
        raise LogFormatError(f"{path}: is {kind}, expected a regular CSV file (a pipe or "
                             "device is not read: save the data to a file first)")
    try:
        gz = is_gzip(path)
    except OSError as exc:
        raise LogFormatError(f"{name}: cannot read ({exc.strerror or exc})") from None
    if path.name.lower().endswith(".gz") and not gz:
        raise LogFormatError(f"{name}: cannot read: named .gz but not gzip-compressed "
                             "(rename it to .csv if it is plain text)")
    header = _read_header(path, name)
    dup = {h for h in header if header.count(h) > 1}
    if dup:
        raise LogFormatError(f"{name}: duplicate column name(s) {sorted(dup)}")
    for c in required:
        if c not in header:
            raise LogFormatError(f"{name}: missing column {c!r} (the schema requires "
                                 f"{', '.join(required)}; found {', '.join(header)})")
    keep = header if columns is None else [h for h in header if h in set(columns) | set(required)]
    col = _read_columns(path, name, header, keep, progress)
    if not len(col[keep[0]]):
        raise LogFormatError(f"{name}: no data rows")
    for c in keep:
        bad = ~np.isfinite(col[c])
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(f"{name}: column {c!r} has {int(bad.sum())} NaN/inf value(s), "
                                 f"first at row {i} (line {i + 2}); expected finite numbers "
                                 f"(an empty field counts as NaN)")
    t = col.get("t_s")
    if t is not None:
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            kind = "duplicate" if d[i - 1] == 0 else "decreasing"
            raise LogFormatError(f"{name}: column 't_s' is not strictly increasing: {kind} time "
                                 f"at row {i} (line {i + 2}): {float(t[i - 1]):.9g} -> {float(t[i]):.9g}")
    if min_vx is not None and "vx_mps" in col:
        bad = col["vx_mps"] <= min_vx
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(f"{name}: column 'vx_mps' must be > {min_vx:g} m/s (the models "
                                 f"divide by v_x), but row {i} (line {i + 2}) has "
                                 f"{col['vx_mps'][i]:g} ({int(bad.sum())} such rows)")
    kw = {a: col.pop(c, None) for c, a in _ATTR.items()}
    return DriveLog(**kw, extra=col, source=name)


#: plausible range of each schema column for a road vehicle, and the likely unit mistake
#: when a value falls outside (:func:`check_plausible`)
PLAUSIBLE = {
    "vx_mps": (-15.0, 90.0, "speed in km/h instead of m/s? (90 m/s = 324 km/h)"),
    "delta_roadwheel_rad": (-0.8, 0.8, "road-wheel angle in degrees instead of rad, or the "
                                       "steering-wheel angle instead of the road-wheel angle?"),
    "yaw_rate_radps": (-2.5, 2.5, "yaw rate in deg/s instead of rad/s?"),
    "ay_mps2": (-25.0, 25.0, "lateral acceleration in ft/s^2 or mm/s^2 instead of m/s^2?"),
    "vy_mps": (-30.0, 30.0, "lateral velocity in km/h instead of m/s?"),
    "yL_m": (-50.0, 50.0, "lateral offset in cm or mm instead of m?"),
    "psiL_rad": (-1.6, 1.6, "relative heading in degrees instead of rad?"),
    "Ff_N": (-1e6, 1e6, "axle force in a unit other than N?"),
    "Fr_N": (-1e6, 1e6, "axle force in a unit other than N?"),
    "rho_1pm": (-1.0, 1.0, "curvature in a unit other than 1/m?"),
}
#: plausible range per unit suffix (``<quantity>_<unit>``), for a log column outside the
#: schema table above (e.g. ``ax_mps2``, ``beta_rad``, ``deltaFL_rad`` of the Revs log) that
#: an estimator reads: ``unit -> (lo, hi, likely mistake)``. These units are also the ones a
#: plug-in observer may name (:func:`is_log_column`); ``s`` (time-like) has no range.
UNIT_RANGES = {
    "mps": (-90.0, 90.0, "a speed in km/h instead of m/s?"),
    "mps2": (-25.0, 25.0, "an acceleration in ft/s^2, mm/s^2 or g instead of m/s^2?"),
    "rad": (-6.3, 6.3, "an angle in degrees instead of rad?"),
    "deg": (-360.0, 360.0, "an angle in a unit other than degrees?"),
    "radps": (-5.0, 5.0, "an angular rate in deg/s instead of rad/s?"),
    "radps2": (-50.0, 50.0, "an angular acceleration in deg/s^2 instead of rad/s^2?"),
    "m": (-1e5, 1e5, "a length in mm instead of m?"),
    "N": (-1e6, 1e6, "a force in a unit other than N?"),
    "Nm": (-1e6, 1e6, "a torque in a unit other than N m?"),
    "1pm": (-1.0, 1.0, "a curvature in a unit other than 1/m?"),
    "s": (-np.inf, np.inf, ""),
}
_COLUMN_RE = re.compile(r"[A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)*_([A-Za-z0-9]+)")


def is_log_column(name: str) -> bool:
    """``name`` follows the units-in-name convention ``<quantity>_<unit>`` with a unit of
    :data:`UNIT_RANGES` (``ax_mps2``, ``deltaFL_rad``; not ``ax`` nor ``ax_g``)."""
    m = _COLUMN_RE.fullmatch(str(name))
    return bool(m) and m.group(1) in UNIT_RANGES


def log_header(path) -> list[str]:
    """The column names of a log file's header line (the file is not read further)."""
    path = Path(path)
    return _read_header(path, path.name)


#: sampling interval range [s]: 10 kHz .. 2 Hz
DT_RANGE = (1e-4, 0.5)
#: any |value| above this in any column is refused even with ``accept=True``
ABSURD = 1e12


def _consistency(log: DriveLog, wheelbase: float) -> str | None:
    """Cross-channel unit check on the moving rows (|v_x| > 5 m/s) with enough excitation:
    the yaw rate must follow ``r = k v_x delta / L`` with ``0.08 < k < 12`` (kinematic
    ``k = 1``; understeer lowers it, degrees instead of rad give ``k ~ 1/57``, a
    steering-wheel angle ``k ~ 1/15``, a yaw rate in deg/s ``k ~ 57``), and ``a_y``, if
    present, must follow ``a_y = k v_x r + c`` with ``0.5 < k < 2`` (steady turning ``k = 1``;
    speed in km/h gives 0.28, a_y in g 0.10). Returns the message of the first violation."""
    mv = np.abs(log.vx) > 5.0
    if mv.sum() < 100:
        return None
    x = log.vx[mv] * log.delta[mv] / wheelbase
    r = log.yaw_rate[mv]
    if np.std(x) > 0.02 and np.std(r) > 0.02:
        xc, rc = x - x.mean(), r - r.mean()
        k = float(np.dot(xc, rc) / np.dot(xc, xc))
        if k < 0:
            return ("columns 'delta_roadwheel_rad' and 'yaw_rate_radps' have opposite signs "
                    f"(yaw rate = {k:.3g} v_x delta / L): both must be positive to the left")
        if k < 0.08:
            return (f"column 'delta_roadwheel_rad' is too large for the yaw rate (yaw rate = "
                    f"{k:.3g} v_x delta / L, expected 0.08..12, kinematic 1): degrees instead "
                    "of rad, or the steering-wheel angle instead of the road-wheel angle?")
        if k > 12:
            return (f"column 'yaw_rate_radps' is too large for the steering (yaw rate = "
                    f"{k:.3g} v_x delta / L, expected 0.08..12): deg/s instead of rad/s?")
    if log.ay is not None:
        z = log.vx[mv] * r
        a = log.ay[mv]
        if np.std(z) > 0.5:
            zc = z - z.mean()
            k = float(np.dot(zc, a - a.mean()) / np.dot(zc, zc))
            if not 0.5 < k < 2.0:
                return (f"columns 'vx_mps', 'yaw_rate_radps', 'ay_mps2' disagree: a_y = {k:.3g} "
                        "v_x r (expected about 1): speed in km/h gives 0.28, a_y in g 0.10, "
                        "a_y in ft/s^2 3.3")
    return None


# ------------------------------------------------------------------ changes of unit -------
# A unit can change in the middle of a log (a logger reconfigured, two files concatenated):
# the whole-column checks above then pass on the majority of rows. Each channel is checked
# for a change of scale at one row that persists (:func:`scale_change`).

#: a persistent change of the sampling interval by this factor (either way) is a change of
#: time unit (ms: x1000, us: x1e6, min -> s: x60), not a change of logger rate (100 -> 10 Hz
#: is x10)
DT_SCALE_CHANGE = 30.0
#: a step of a channel by this factor (either way) at one row that persists is a change of
#: unit (km/h x3.6, ft/s^2 x3.3, lbf x4.4, g x9.8, deg x57, cm x100, mm x1000, steering wheel x15)
SCALE_STEP = 3.0
#: rows before and after a step that must stay at their level (a spike is not a change)
STEP_HOLD = 5
#: per column: the level below which a step is not judged (standstill, straight driving,
#: quantised low-speed wheel speeds), in the column's unit
STEP_FLOOR = {"vx_mps": 2.0, "delta_roadwheel_rad": 0.005, "yaw_rate_radps": 0.02,
              "ay_mps2": 0.5, "vy_mps": 0.05, "yL_m": 0.05, "psiL_rad": 0.005,
              "Ff_N": 1000.0, "Fr_N": 1000.0, "rho_1pm": 1e-3}
#: the likely mistake for a step by a factor ``f`` (first match of ``lo <= f <= hi``) and the
#: columns it can happen to (``None``: any column)
_STEP_WHY = ((3.0, 4.2, "km/h (x3.6) or ft (x3.3)", ("vx_mps", "vy_mps", "yL_m", "ay_mps2")),
             (8.5, 11.0, "g (x1/9.81) or x10", None),
             (12.0, 20.0, "the steering-wheel angle (ratio ~15)", ("delta_roadwheel_rad",)),
             (45.0, 70.0, "degrees (x57.3)", ("delta_roadwheel_rad", "yaw_rate_radps",
                                               "psiL_rad")),
             (80.0, 120.0, "cm (x100)", None), (800.0, 1200.0, "milli-units (x1000)", None))


def _step_why(f: float, column: str | None = None) -> str:
    """The likely cause of a persistent step by the factor ``f`` in ``column``: a unit
    mistake that fits both the factor and the column, else a jump of the signal itself
    (a re-initialised or faulty sensor) rather than a unit."""
    g = max(f, 1.0 / f)
    for lo, hi, why, cols in _STEP_WHY:
        if lo <= g <= hi and (cols is None or column is None or column in cols):
            return f"{why} from that row?"
    return (f"no unit of this column differs by x{g:.3g}: a jump of the signal itself (a "
            "sensor or an INS re-initialised, or a fault) rather than a change of unit?")


def _noise_of_steps(x: np.ndarray, block: int = 200, blocks: int = 2000) -> float:
    """Robust std of the one-sample changes of a channel in its quietest stretches: the 10th
    percentile over blocks of ``block`` changes (at most ``blocks`` blocks, evenly spread
    over the log) of 1.4826 x the median nonzero change (a held channel, e.g. vision frames
    at 25 Hz in a 1 kHz log, has mostly zero changes; a block with fewer than 10 % nonzero
    changes counts as 0). Blocks keep a part of the log in another unit from setting the
    level."""
    n = (len(x) - 1) // block
    if n < 1:
        d = np.abs(np.diff(x))
        d = d[d != 0]
        return float(1.482602218505602 * np.median(d)) if len(d) else 0.0
    starts = np.unique(np.linspace(0, n - 1, min(n, blocks)).astype(np.int64)) * block
    idx = starts[:, None] + np.arange(block)[None, :]
    D = np.abs(x[idx + 1] - x[idx])
    nz = D != 0
    share = nz.mean(axis=1)
    D = np.where(nz, D, np.inf)
    D.sort(axis=1)
    cnt = nz.sum(axis=1)
    med = np.where(cnt > 0, D[np.arange(len(D)), np.maximum(cnt - 1, 0) // 2], 0.0)
    mad = np.where(share >= 0.1, 1.482602218505602 * med, 0.0)
    return float(np.percentile(mad, 10))


def _time_scale_change(t: np.ndarray) -> tuple[int, float, float] | None:
    """``(row, dt_before, dt_after)`` where the sampling interval changes by more than
    :data:`DT_SCALE_CHANGE` and stays so for at least 20 steps (a single long step is a gap,
    not a change of unit); ``None`` otherwise."""
    d = np.diff(t)
    if len(d) < 40:
        return None
    med = float(np.median(d))
    if not med > 0:
        return None
    far = np.abs(np.log(np.maximum(d, 1e-300) / med)) > np.log(DT_SCALE_CHANGE)
    if not far.any():
        return None
    edges = np.flatnonzero(np.diff(np.r_[0, far.astype(np.int8), 0]))
    starts, ends = edges[::2], edges[1::2]
    for a, b in zip(starts, ends):
        if b - a >= 20:
            # the step into the new unit (t[k] - t[k-1], index k - 1) is far from both regimes:
            # it ends a run at the start, or begins a run after it
            row = int(a) + 1 if a > 0 else int(b)
            before = float(np.median(d[max(a - 20, 0):a])) if a > 0 else float(np.median(d[a:b]))
            after = float(np.median(d[a + 1:b])) if a > 0 else float(np.median(d[b:b + 20]))
            return (row, before, after)
    return None


def _value_step(x: np.ndarray, floor: float, gap: np.ndarray) -> tuple[int, float] | None:
    """First row ``k`` where the channel steps by a factor ``f = x_k / x_{k-1}`` with
    ``|ln f| >= ln`` :data:`SCALE_STEP` (same sign, the larger level above ``floor`` and 10
    noise stds, the smaller above 10 noise stds, the step above 20 noise stds) and holds
    both levels :data:`STEP_HOLD` rows before and after (a spike is not a change of unit); a
    row after a time gap (``gap[k]``) is skipped.
    A change of unit where the channel crosses zero is not seen here (the range and
    cross-channel checks see it). Returns ``(k, f)`` or ``None``."""
    n = len(x)
    h = STEP_HOLD
    if n < 2 * h + 2:
        return None
    sd = _noise_of_steps(x)
    level = max(floor, 10.0 * sd)
    # candidates first (a step above 20 noise stds is rare in a log), then the other tests
    d = np.diff(x)
    i = np.flatnonzero(np.abs(d) > 20.0 * sd)
    i = i[~gap[i + 1]]
    a, b = x[i], x[i + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = b / a
    lo, hi = np.minimum(np.abs(a), np.abs(b)), np.maximum(np.abs(a), np.abs(b))
    keep = ((hi > level) & (lo > 10.0 * sd) & (q > 0)
            & (np.abs(np.log(np.where(q > 0, q, 1.0))) >= np.log(SCALE_STEP)))
    for j in np.flatnonzero(keep):
        k = int(i[j]) + 1
        if k < h or k + h > n:
            continue
        jump = abs(x[k] - x[k - 1])
        if np.all(np.abs(x[k - h:k] - x[k - 1]) < 0.25 * jump) and \
                np.all(np.abs(x[k:k + h] - x[k]) < 0.25 * jump):
            return k, float(q[j])
    return None


def _noise_shift_row(x: np.ndarray, a: int, b: int) -> int | None:
    """Row in ``[a, b)`` where the level of ``log |second difference|`` of ``x`` shifts most
    (the largest two-sample t statistic of a single mean shift): a change of unit multiplies
    the channel's noise and curvature by its factor, so it moves this level by ``ln f`` from
    the row of the change on, even where the channel itself is near zero. ``None`` when the
    window is too short."""
    a, b = max(int(a), 0), min(int(b), len(x))
    if b - a < 40:
        return None
    d2 = np.abs(x[a + 2:b] - 2.0 * x[a + 1:b - 1] + x[a:b - 2])
    pos = d2[d2 > 0]
    if len(pos) < 20:
        return None
    L = np.log(np.maximum(d2, pos.min()))
    n = len(L)
    c = np.cumsum(L)
    j = np.arange(5, n - 5)
    m1 = c[j - 1] / j
    m2 = (c[-1] - c[j - 1]) / (n - j)
    stat_ = np.abs(m2 - m1) * np.sqrt(j * (n - j) / n)
    i = int(j[np.argmax(stat_)])
    return a + i        # the first level-shifted second difference is the first whose three
    #                     rows are mostly in the new unit (found on shifted test channels)


def _gain_change(y: np.ndarray, z: np.ndarray, blocks: int = 400):
    """Change of the gain of ``y = k z + c`` at one row: the split into two stretches with
    their own ``(k, c)`` that explains the data best (candidate splits every ``n / blocks``
    rows, each side holding at least 10 % of the excitation ``sum (z - mean z)^2``). Returns
    ``(row, k_after / k_before, (a, b))`` when the ratio is at least :data:`SCALE_STEP` either
    way and the split removes at least half of the residual of one gain (``a, b``: rows
    around the split where the change must lie; the row is only as precise as the excitation
    there); ``None`` otherwise."""
    n = len(y)
    if n < 200:
        return None
    edges = np.unique(np.linspace(0, n, min(blocks, n // 20) + 1).astype(np.int64))
    idx = edges[:-1]
    S = {k: np.add.reduceat(v, idx) for k, v in (("1", np.ones(n)), ("z", z), ("y", y),
                                                   ("zz", z * z), ("zy", z * y),
                                                   ("yy", y * y))}
    C = {k: np.cumsum(v) for k, v in S.items()}
    T = {k: v[-1] for k, v in C.items()}

    def fit(s):
        m = np.maximum(s["1"], 1.0)
        vzz = s["zz"] - s["z"] ** 2 / m
        vzy = s["zy"] - s["z"] * s["y"] / m
        vyy = s["yy"] - s["y"] ** 2 / m
        with np.errstate(divide="ignore", invalid="ignore"):
            k = vzy / vzz
            sse = vyy - vzy * k
        return k, sse, vzz

    k_all, sse_all, e_all = fit(T)
    if not (e_all > 0 and sse_all > 0):
        return None
    left = {k: v[:-1] for k, v in C.items()}
    right = {k: T[k] - v for k, v in left.items()}
    kl, sl, el = fit(left)
    kr, sr, er = fit(right)
    ok = (el >= 0.1 * e_all) & (er >= 0.1 * e_all) & (kl > 0) & (kr > 0)
    if not ok.any():
        return None
    tot = np.where(ok, sl + sr, np.inf)
    i = int(np.argmin(tot))
    ratio = float(kr[i] / kl[i])
    if not (abs(np.log(ratio)) >= np.log(SCALE_STEP) and tot[i] <= 0.5 * sse_all):
        return None
    # the row inside the two blocks around the split: least squares with both gains fixed
    a, b = int(edges[max(i, 0)]), int(edges[min(i + 2, len(edges) - 1)])
    cl = (left["y"][i] - kl[i] * left["z"][i]) / max(left["1"][i], 1.0)
    cr = (right["y"][i] - kr[i] * right["z"][i]) / max(right["1"][i], 1.0)
    el_ = (y[a:b] - kl[i] * z[a:b] - cl) ** 2
    er_ = (y[a:b] - kr[i] * z[a:b] - cr) ** 2
    cost = np.r_[0.0, np.cumsum(el_)] + (er_.sum() - np.r_[0.0, np.cumsum(er_)])
    # splits that fit nearly as well (a stretch without excitation between them): the change
    # lies somewhere in there
    near = np.flatnonzero(tot <= tot[i] + 0.05 * (sse_all - tot[i]))
    return a + int(np.argmin(cost)), ratio, (int(edges[max(near.min(), 0)]),
                                             int(edges[min(near.max() + 2, len(edges) - 1)]))


def scale_change(log: DriveLog, columns=None) -> str | None:
    """Message naming the first change of unit inside the log, or ``None``.

    * ``t_s``: the sampling interval changes by :data:`DT_SCALE_CHANGE` or more and stays
      (e.g. seconds, then milliseconds from some row);
    * every other column of :data:`PLAUSIBLE` (``columns``: a subset): a persistent step by
      :data:`SCALE_STEP` or more at one row (:func:`_value_step`; a spike or a step across a
      time gap is not one);
    * ``ay_mps2`` also against ``v_x r`` (:func:`_gain_change`): a noisy accelerometer's
      step can hide in its noise, the gain between the channels cannot.

    Rows are counted from 0 (file line = row + 2)."""
    name = log.source or "log"
    cols = log.columns()
    if columns is not None:
        cols = {c: v for c, v in cols.items() if c in set(columns) | {"t_s"}}
    found = []
    ch = _time_scale_change(log.t)
    if ch is not None:
        k, d0, d1 = ch
        f = d1 / d0
        why = ("time in milliseconds from that row?" if 300 <= f <= 3000 else
               "time in microseconds from that row?" if 3e5 <= f <= 3e6 else
               "a change of time unit from that row?")
        found.append((k, f"column 't_s' changes scale at row {k} (line {k + 2}): sampling "
                         f"interval {d0:.4g} s before, {d1:.4g} s after (x{f:.3g}): {why}"))
    d = np.diff(log.t)
    med = float(np.median(d)) if len(d) else 0.0
    gap = np.r_[False, d > 3.0 * med] if len(d) else np.zeros(len(log), bool)
    for c, floor in STEP_FLOOR.items():
        x = cols.get(c)
        if x is None:
            continue
        st = _value_step(np.asarray(x, float), floor, gap)
        if st is not None:
            k, f = st
            found.append((k, f"column {c!r} changes scale at row {k} (line {k + 2}): "
                             f"{float(x[k - 1]):.4g} -> {float(x[k]):.4g} (x{f:.3g}) and stays: "
                             f"{_step_why(f, c)}"))
    if not found and "ay_mps2" in cols and log.ay is not None:
        mv = np.flatnonzero(np.abs(log.vx) > 5.0)
        if len(mv) >= 200:
            g = _gain_change(log.ay[mv], log.vx[mv] * log.yaw_rate[mv])
            if g is not None:
                k, f = int(mv[g[0]]), g[1]
                lo, hi = int(mv[g[2][0]]), int(mv[min(g[2][1], len(mv) - 1)])
                # the row itself from the accelerometer's noise, scaled by the same factor
                j = _noise_shift_row(log.ay, lo, hi + 1)
                k = k if j is None else j
                found.append((k, f"columns 'ay_mps2' and 'vx_mps' x 'yaw_rate_radps' change "
                                 f"their ratio at row {k} (line {k + 2}) by x{f:.3g} and keep "
                                 f"it: a unit of 'ay_mps2' (or of 'vx_mps' / 'yaw_rate_radps') "
                                 f"changes there: {_step_why(f, 'ay_mps2')}"))
    if not found:
        return None
    k, msg = min(found, key=lambda kv: kv[0])
    return f"{name}: {msg}"


def check_plausible(log: DriveLog, wheelbase: float | None = None, accept: bool = False):
    """Refuse a log whose values cannot be those of a road vehicle in SI units.

    Raises :class:`LogFormatError` naming the column, the row and the likely unit mistake
    when a unit changes inside the log (:func:`scale_change`), a column leaves its
    :data:`PLAUSIBLE` range (when the column's noise level jumps shortly before, the row of
    that jump is named as where the unit changes), the median sampling interval leaves
    :data:`DT_RANGE` (time in ms or us), or the channels disagree (:func:`_consistency`,
    needs ``wheelbase`` [m]). ``accept=True`` (``--accept-out-of-range``) skips these checks
    for a log that really is out of range; values above :data:`ABSURD` are refused always.
    """
    name = log.source or "log"
    cols = log.columns()
    for c, v in cols.items():
        big = np.abs(v) > (ABSURD if c != "t_s" else 1e15)
        if big.any():
            i = int(np.argmax(big))
            raise LogFormatError(f"{name}: column {c!r} has an absurd value {v[i]:.3g} at row "
                                 f"{i} (line {i + 2}); refused before computing")
    if accept:
        return
    tail = " (--accept-out-of-range accepts it)"
    msg = scale_change(log)
    if msg:
        raise LogFormatError(msg + tail)
    ranges = dict(PLAUSIBLE)
    for c in cols:              # any other column read: the range of its unit
        if c not in ranges and is_log_column(c) and c != "t_s":
            unit = _COLUMN_RE.fullmatch(c).group(1)
            if np.isfinite(UNIT_RANGES[unit][1]):
                ranges[c] = UNIT_RANGES[unit]
    for c, (lo, hi, why) in ranges.items():
        v = cols.get(c)
        if v is None:
            continue
        out = (v < lo) | (v > hi)
        if out.any():
            i = int(np.argmax(out))
            j = _noise_shift_row(v, i - 5000, i + 1) if i >= 200 else None
            if j is not None and 0 < j <= i:
                L = np.log(np.abs(np.diff(v[max(j - 200, 0):i + 1], 2)) + 1e-300)
                k = j - max(j - 200, 0)
                if k > 20 and np.median(L[k:]) - np.median(L[:k - 2]) >= np.log(SCALE_STEP):
                    raise LogFormatError(
                        f"{name}: column {c!r} changes scale at row {j} (line {j + 2}): its "
                        f"noise grows there and from row {i} (line {i + 2}) it is outside the "
                        f"plausible range [{lo:g}, {hi:g}] ({v[i]:.4g}): {why}{tail}")
            raise LogFormatError(f"{name}: column {c!r} = {v[i]:.4g} at row {i} (line {i + 2}) "
                                 f"is outside the plausible range [{lo:g}, {hi:g}]: {why}{tail}")
    if len(log) > 1:
        dt = float(np.median(np.diff(log.t)))
        if not DT_RANGE[0] <= dt <= DT_RANGE[1]:
            why = ("time in milliseconds instead of seconds?" if dt > DT_RANGE[1]
                   else "time in a unit smaller than seconds, or a sampling rate above 10 kHz?")
            raise LogFormatError(f"{name}: column 't_s' has a median sampling interval of "
                                 f"{dt:.4g} s, outside [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s: "
                                 f"{why}{tail}")
    if wheelbase is not None:
        msg = _consistency(log, wheelbase)
        if msg:
            raise LogFormatError(f"{name}: {msg}{tail}")


def despike(x, threshold: float):
    """Replace isolated one-sample spikes (|x_k - median(x_{k-1..k+1})| > threshold) by the
    3-sample median. Returns (cleaned copy, indices replaced). The input is not modified."""
    x = np.asarray(x, dtype=float)
    y = x.copy()
    if len(x) < 3:
        return y, np.array([], dtype=int)
    a, b, c = x[:-2], x[1:-1], x[2:]
    med = np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))   # median of three
    idx = np.flatnonzero(np.abs(x[1:-1] - med) > threshold) + 1
    y[idx] = med[idx - 1]
    return y, idx


def revs_log_path() -> Path:
    """Path of the shipped real log (data/revs_250lm_2014/revs_250lm_2014.csv.gz)."""
    return repo_root() / "data" / "revs_250lm_2014" / "revs_250lm_2014.csv.gz"


def repo_root() -> Path:
    """The repository root (the folder holding ``lib/``; this file is lib/vehicle_observers/data/logs.py)."""
    return Path(__file__).resolve().parents[3]


def load_revs(min_vx: float | None = 0.0) -> DriveLog:
    """The Revs 250 LM log (cite Leanza, Reina, Blanco-Claraco, Sensors 2021; see PROVENANCE)."""
    return load_log(revs_log_path(), min_vx=min_vx)
