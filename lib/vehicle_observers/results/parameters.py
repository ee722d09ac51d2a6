"""The notebooks' papermill parameters, checked before anything runs.

Every notebook has a ``parameters`` cell (``quick = False``, ``seed = 0``) that papermill
overrides: ``-p quick True`` gives a boolean, but ``-r quick no`` (raw) gives the *string*
``"no"``, which Python takes as true, and ``-p seed 1.5`` a float that ``int()`` would
silently cut to 1. :func:`validate_parameters` (called by
:class:`~vehicle_observers.results.reporting.Report`, so by every notebook before its first
computation) accepts only a real boolean for ``quick`` and a real integer for ``seed``; a
string is refused even when it spells a boolean, because the notebook's own cells read the
raw variable (``mc_runs = 40 if quick else 100``) and would take ``"False"`` as true.
"""

from __future__ import annotations

import numbers

import numpy as np

#: largest seed accepted (numpy's SeedSequence takes any non-negative integer; this keeps
#: the seed a 64-bit integer in metrics.json)
MAX_SEED = 2 ** 63 - 1


class ParameterError(ValueError):
    """A notebook parameter of the wrong type or value (one line naming it)."""


def validate_parameters(quick=False, seed=0) -> tuple[bool, int]:
    """``(quick, seed)`` as ``(bool, int)`` or :class:`ParameterError` naming the parameter,
    its value and how to pass it (module docstring)."""
    if isinstance(quick, str):
        raise ParameterError(
            f"parameter quick = {quick!r} is a string (papermill -r passes text, and any "
            "non-empty text is true in Python); pass a boolean: papermill -p quick True / "
            "-p quick False")
    if not isinstance(quick, (bool, np.bool_)):
        raise ParameterError(f"parameter quick must be True or False, got {quick!r} "
                             f"({type(quick).__name__})")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise ParameterError(f"parameter seed must be an integer, got {seed!r} "
                             f"({type(seed).__name__}); e.g. papermill -p seed 3")
    if not 0 <= int(seed) <= MAX_SEED:
        raise ParameterError(f"parameter seed must be in [0, 2^63 - 1], got {seed}")
    return bool(quick), int(seed)
