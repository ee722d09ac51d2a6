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
import tempfile
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


def write_csv(path, columns: dict[str, np.ndarray], fmt: str = "%.10g"):
    """Write named equal-length columns as CSV, completely or not at all."""
    path = Path(path)
    names = list(columns)
    data = np.column_stack([np.asarray(columns[c], dtype=float) for c in names])
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            np.savetxt(fh, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _open_text(path: Path):
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
    return open(path, encoding="utf-8", newline="")


def load_log(path, min_vx: float | None = 0.0, required=REQUIRED) -> DriveLog:
    """Load and validate a drive log (see module docstring for the schema).

    Parameters
    ----------
    min_vx : speed floor [m/s]; every ``vx_mps`` sample must be ``> min_vx`` (``None`` skips
        the check, for uses that never divide by ``v_x``).
    required : columns that must be present.
    """
    path = Path(path)
    name = path.name
    if not path.exists():
        raise LogFormatError(f"{path}: no such file")
    try:
        with _open_text(path) as fh:
            reader = csv.reader(fh)
            try:
                header = [h.strip() for h in next(reader)]
            except StopIteration:
                raise LogFormatError(f"{name}: empty file (expected a header line with "
                                     f"{', '.join(REQUIRED)})") from None
            rows = list(reader)
    except (OSError, UnicodeDecodeError, gzip.BadGzipFile) as exc:
        raise LogFormatError(f"{name}: cannot read ({exc})") from exc
    dup = {h for h in header if header.count(h) > 1}
    if dup:
        raise LogFormatError(f"{name}: duplicate column name(s) {sorted(dup)}")
    for c in required:
        if c not in header:
            raise LogFormatError(f"{name}: missing column {c!r} (the schema requires "
                                 f"{', '.join(required)}; found {', '.join(header)})")
    if not rows:
        raise LogFormatError(f"{name}: no data rows")
    ncol = len(header)
    data = np.empty((len(rows), ncol))
    for i, row in enumerate(rows):
        if len(row) != ncol:
            raise LogFormatError(f"{name}: row {i} (line {i + 2}) has {len(row)} fields, "
                                 f"expected {ncol}")
        for j, s in enumerate(row):
            try:
                data[i, j] = float(s)
            except ValueError:
                raise LogFormatError(f"{name}: column {header[j]!r}, row {i} (line {i + 2}): "
                                     f"{s!r} is not a number") from None
    for j, c in enumerate(header):
        bad = ~np.isfinite(data[:, j])
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(f"{name}: column {c!r} has {int(bad.sum())} NaN/inf value(s), "
                                 f"first at row {i} (line {i + 2}); expected finite numbers")
    col = {c: data[:, j].copy() for j, c in enumerate(header)}
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


def despike(x, threshold: float):
    """Replace isolated one-sample spikes (|x_k - median(x_{k-1..k+1})| > threshold) by the
    3-sample median. Returns (cleaned copy, indices replaced). The input is not modified."""
    x = np.asarray(x, dtype=float)
    y = x.copy()
    if len(x) < 3:
        return y, np.array([], dtype=int)
    med = np.median(np.column_stack([x[:-2], x[1:-1], x[2:]]), axis=1)
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
