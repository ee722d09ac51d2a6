"""The one conversion of array inputs at the library's public entries.

:class:`~vehicle_observers.data.logs.DriveLog`, the registry's ``estimate``
(:mod:`vehicle_observers.estimation.registry`) and every observer's ``run``
(:func:`vehicle_observers.core.protocol.check_data`) read their arrays through
:func:`as_array` and :func:`as_time`, so a list, a tuple, a NumPy array, a pandas or polars
Series or DataFrame and a ``datetime64`` / ``timedelta64`` time all give the same float
arrays, and a wrong input is refused where it enters with the package's own error
(:class:`~vehicle_observers.core.errors.ObserverArgumentError`, or the caller's, e.g.
:class:`~vehicle_observers.core.errors.LogFormatError`) naming the argument, the row and the
column:

* time: 1-D, finite (no NaT), strictly increasing (a repeated or swapped timestamp is named
  with its row); ``datetime64`` / ``timedelta64`` converted to seconds from the first sample;
* values: numbers (not text, not dates), the expected number of dimensions, finite unless
  the caller allows NaN.
"""

from __future__ import annotations

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError


def _plain(value):
    """``value`` as a NumPy array: a pandas / polars Series or DataFrame through its own
    ``to_numpy``, anything else through ``np.asarray``."""
    to_numpy = getattr(value, "to_numpy", None)
    if callable(to_numpy) and not isinstance(value, np.ndarray):
        return np.asarray(to_numpy())
    return np.asarray(value)


def is_frame(value) -> bool:
    """A pandas or polars DataFrame (a table with named columns)."""
    return hasattr(value, "columns") and callable(getattr(value, "to_numpy", None)) and \
        not isinstance(value, np.ndarray) and hasattr(value, "shape") and len(value.shape) == 2


def frame_columns(frame) -> dict:
    """``{name: 1-D array}`` of a pandas or polars DataFrame (or of a mapping of columns)."""
    if isinstance(frame, dict):
        return dict(frame)
    names = [str(c) for c in frame.columns]
    return {n: frame[n] for n in names}


def as_array(value, arg: str, who: str = "", ndim: int | None = 1, allow_nan: bool = False,
             error=ObserverArgumentError, column_names=None) -> np.ndarray:
    """``value`` as a contiguous float64 array (module docstring). ``ndim``: 1 or 2 (a 1-D
    value is a column when 2 is asked), ``None``: any. Raises ``error`` naming ``who``,
    ``arg`` and the row (and column) of the first bad value."""
    pre = f"{who}: " if who else ""
    try:
        a = _plain(value)
    except Exception as exc:  # noqa: BLE001 - whatever cannot become an array
        raise error(f"{pre}{arg} cannot be read as an array ({type(exc).__name__}: {exc})") \
            from None
    if a.dtype.kind in "mM":
        raise error(f"{pre}{arg} holds dates / durations ({a.dtype}); expected numbers in SI "
                    "units")
    if a.dtype.kind not in "biuf":
        raise error(f"{pre}{arg} must hold numbers, got dtype {a.dtype}"
                    + (f" (e.g. {a.ravel()[0]!r})" if a.size else ""))
    if ndim == 2 and a.ndim == 1:
        a = a[:, None]
    if ndim is not None and a.ndim != ndim:
        raise error(f"{pre}{arg} must be a {ndim}-D numeric array "
                    f"{'(N,)' if ndim == 1 else '(N, k)'}, got shape {a.shape} of {a.dtype}")
    a = np.ascontiguousarray(a, dtype=float)
    if not allow_nan and a.size and not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        where = f"row {bad[0]}"
        if a.ndim == 2:
            col = int(bad[1])
            name = column_names[col] if column_names is not None and col < len(column_names) \
                else col
            where += f", column {name}"
        n = int((~np.isfinite(a)).sum())
        raise error(f"{pre}{arg} has {n} NaN/inf value(s), first at {where} "
                    f"({a[tuple(bad)]}); expected finite numbers")
    return a


def as_time(value, arg: str = "t", who: str = "", error=ObserverArgumentError,
            min_len: int = 1) -> np.ndarray:
    """Time [s] (N,) float64 from numbers or ``datetime64`` / ``timedelta64`` (seconds from
    the first sample); refused unless 1-D, of at least ``min_len`` samples, finite and
    strictly increasing (the first bad row named)."""
    pre = f"{who}: " if who else ""
    try:
        a = _plain(value)
    except Exception as exc:  # noqa: BLE001
        raise error(f"{pre}{arg} cannot be read as an array ({type(exc).__name__}: {exc})") \
            from None
    if a.ndim != 1 or len(a) < min_len:
        raise error(f"{pre}{arg} must be (N,) with N >= {min_len}, got shape {a.shape}")
    if a.dtype.kind in "mM":
        nat = np.isnat(a)
        if nat.any():
            i = int(np.argmax(nat))
            raise error(f"{pre}{arg} has {int(nat.sum())} missing time(s) (NaT), first at row {i}")
        a = (a - a[0]) / np.timedelta64(1, "s") if len(a) else a.astype(float)
    t = as_array(a, arg, who, ndim=1, error=error, allow_nan=True)
    bad = ~np.isfinite(t)
    if bad.any():
        i = int(np.argmax(bad))
        raise error(f"{pre}{arg} must be finite and strictly increasing: {int(bad.sum())} "
                    f"NaN/inf value(s), first at row {i} ({t[i]})")
    d = np.diff(t)
    if len(d) and not np.all(d > 0):
        k = int(np.argmax(~(d > 0))) + 1
        what = "repeats" if d[k - 1] == 0 else "goes back"
        raise error(f"{pre}{arg} must be strictly increasing: it {what} at row {k} "
                    f"({arg}[{k}] = {t[k]!r} after {t[k - 1]!r})")
    return t
