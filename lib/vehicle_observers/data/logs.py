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

Any other numeric column is kept in :attr:`DriveLog.extra`. Bad input raises
:class:`~vehicle_observers.core.errors.LogFormatError` naming the file, column and row (rows are
counted as data rows from 0; the file line is that + 2) and what was expected; the file is
never modified.
"""

from __future__ import annotations

import csv
import gzip
import io
import os
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


#: rows per batch when writing (the progress callback is called after each)
WRITE_BATCH = 1 << 20
#: longest field accepted in a log [characters] (a longer one is not a number of a log)
MAX_FIELD = 128 * 1024


def partial_path(path) -> Path:
    """The temporary file of an output being written: next to ``path``, named
    ``<name>.partial-<pid>`` (renamed onto ``path`` once complete)."""
    path = Path(path)
    return path.with_name(f"{path.name}.partial-{os.getpid()}")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_partials(path) -> list[Path]:
    """Delete ``<name>.partial-<pid>`` files next to ``path`` whose process is gone (left by
    a run killed with SIGKILL). Returns the files removed."""
    path = Path(path)
    gone = []
    for f in path.parent.glob(f"{path.name}.partial-*"):
        pid = f.name.rsplit("-", 1)[-1]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            f.unlink(missing_ok=True)
            gone.append(f)
    return gone


#: partial files being written by this process (removed by the command line on SIGTERM)
ACTIVE_PARTIALS: set = set()


class AtomicOutput:
    """An output CSV written completely or not at all.

    ``with AtomicOutput(path) as out: ...; out.commit(columns)``: on entry, stale partial
    files of killed runs are removed and the partial file is created at once (so an
    unwritable folder fails before any computing); :meth:`commit` writes it and renames it
    onto ``path``; leaving the block without a commit (error, SIGTERM turned into an
    exception) deletes it. The file gets the normal permissions (``0666 & ~umask``).
    """

    def __init__(self, path):
        self.path = Path(path)
        self.tmp = partial_path(self.path)
        self.done = False

    def __enter__(self):
        remove_stale_partials(self.path)
        fd = os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        os.close(fd)
        ACTIVE_PARTIALS.add(self.tmp)
        return self

    def commit(self, columns: dict, progress=None):
        _write_table(self.tmp, columns, progress)
        os.replace(self.tmp, self.path)
        ACTIVE_PARTIALS.discard(self.tmp)
        self.done = True

    def __exit__(self, *exc):
        if not self.done:
            self.tmp.unlink(missing_ok=True)
        ACTIVE_PARTIALS.discard(self.tmp)
        return False


def _write_table(path, columns: dict, progress=None):
    """CSV with polars' writer (header line, comma separated, shortest round-trip floats
    (Ryu), integer / boolean columns as integers), in batches of :data:`WRITE_BATCH` rows with
    ``progress(rows_written, rows)`` after each. polars formats floats more than twice as fast
    as pyarrow's writer."""
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
    with open(path, "wb") as fh:
        fh.write((",".join(names) + "\n").encode())   # plain header line, never quoted
        for a in range(0, n, WRITE_BATCH):
            b = min(n, a + WRITE_BATCH)
            pl.DataFrame({c: x[a:b] for c, x in zip(names, arrs)}).write_csv(
                fh, include_header=False, quote_style="never")
            if progress is not None:
                progress(b, n)


def write_csv(path, columns: dict[str, np.ndarray], progress=None):
    """Write named equal-length columns as CSV (polars), completely or not at all."""
    with AtomicOutput(path) as out:
        out.commit(columns, progress)


def _open_text(path: Path):
    if path.suffix == ".gz":
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
        self.fh = gzip.GzipFile(fileobj=self.raw) if path.suffix == ".gz" else self.raw
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
    """Bytes of CSV text: the file size, or for ``.gz`` the size stored in its trailer (the
    uncompressed size modulo 2^32; the compressed size when that is smaller)."""
    size = path.stat().st_size
    if path.suffix != ".gz" or size < 18:
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
    if path.is_dir():
        raise LogFormatError(f"{path}: is a directory, expected a CSV file")
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


def check_plausible(log: DriveLog, wheelbase: float | None = None, accept: bool = False):
    """Refuse a log whose values cannot be those of a road vehicle in SI units.

    Raises :class:`LogFormatError` naming the column and the likely unit mistake when a
    column leaves its :data:`PLAUSIBLE` range, the median sampling interval leaves
    :data:`DT_RANGE` (time in ms or us), or the channels disagree (:func:`_consistency`,
    needs ``wheelbase`` [m]). ``accept=True`` (``--accept-out-of-range``) skips these checks
    for a log that really is out of range; values above :data:`ABSURD` are refused always.
    """
    name = log.source or "log"
    for c, v in log.columns().items():
        big = np.abs(v) > (ABSURD if c != "t_s" else 1e15)
        if big.any():
            i = int(np.argmax(big))
            raise LogFormatError(f"{name}: column {c!r} has an absurd value {v[i]:.3g} at row "
                                 f"{i} (line {i + 2}); refused before computing")
    if accept:
        return
    for c, (lo, hi, why) in PLAUSIBLE.items():
        v = log.columns().get(c)
        if v is None:
            continue
        out = (v < lo) | (v > hi)
        if out.any():
            i = int(np.argmax(out))
            raise LogFormatError(f"{name}: column {c!r} = {v[i]:.4g} at row {i} (line {i + 2}) "
                                 f"is outside the plausible range [{lo:g}, {hi:g}]: {why} "
                                 f"(--accept-out-of-range accepts it)")
    if len(log) > 1:
        dt = float(np.median(np.diff(log.t)))
        if not DT_RANGE[0] <= dt <= DT_RANGE[1]:
            why = ("time in milliseconds instead of seconds?" if dt > DT_RANGE[1]
                   else "time in a unit smaller than seconds, or a sampling rate above 10 kHz?")
            raise LogFormatError(f"{name}: column 't_s' has a median sampling interval of "
                                 f"{dt:.4g} s, outside [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s: "
                                 f"{why} (--accept-out-of-range accepts it)")
    if wheelbase is not None:
        msg = _consistency(log, wheelbase)
        if msg:
            raise LogFormatError(f"{name}: {msg} (--accept-out-of-range accepts it)")


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
