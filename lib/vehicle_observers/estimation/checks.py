"""Protocol checks of an observer on a drive log: what the library's tests check of every
built-in observer, as one public function for people who write their own.

    from vehicle_observers.estimation import check_observer
    print(check_observer(MyObserver(vehicle, dt), log))      # one line per check
    check_observer(obs, log).raise_if_failed()               # in a test

Checks (:func:`check_observer`), on the log's first stretch in motion (at most ``rows``
rows):

* **names and units**: ``input_names`` / ``output_names`` are log columns
  (``<quantity>_<unit>``, :func:`vehicle_observers.data.logs.is_log_column`) present in the
  log; ``state_names`` follow the same convention;
* **shapes**: ``initial_state`` is 1-D, ``estimate(z)`` is ``(n,)`` with ``n =
  len(state_names)``, ``bounds(z)`` is ``None`` or two ``(n,)`` arrays with ``lo <= hi``,
  ``run`` returns a :class:`~vehicle_observers.core.protocol.Trajectory` of ``(N, n)``
  named ``state_names``; the estimate is finite;
* **compiled equals readable**: ``run`` against
  :func:`~vehicle_observers.core.protocol.run_readable` (the step looped in Python) within
  ``rtol``/``atol`` (when ``run`` is the default readable loop the comparison proves
  nothing and says so);
* **causality**: changing every input and output after sample ``k`` leaves the estimates up
  to ``k`` unchanged, for ``run`` and for the readable loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehicle_observers.core.protocol import ObserverBase, Trajectory, run_readable
from vehicle_observers.data.logs import DriveLog, is_log_column
from vehicle_observers.estimation import segments


@dataclass
class ObserverCheck:
    """Results of :func:`check_observer`: ``(check, passed, detail)`` per check."""

    observer: str
    results: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(p for _, p, _ in self.results)

    def failed(self) -> list:
        return [(c, d) for c, p, d in self.results if not p]

    def __str__(self) -> str:
        return "\n".join(f"{'ok  ' if p else 'FAIL'} {c}: {d}" for c, p, d in self.results)

    def raise_if_failed(self):
        if not self.ok:
            raise AssertionError(f"{self.observer}: " + "; ".join(f"{c}: {d}"
                                                                  for c, d in self.failed()))


def _data(obs, log: DriveLog, rows: int):
    runs, _ = segments.stretches(log.t, segments.moving_rows(log), segments.MAX_GAP_S, 20)
    a, b = runs[0] if runs else (0, len(log))
    b = min(b, a + rows)
    cols = log.columns()
    u = np.column_stack([cols[c][a:b] for c in obs.input_names]) if obs.input_names \
        else np.empty((b - a, 0))
    y = np.column_stack([cols[c][a:b] for c in obs.output_names]) if obs.output_names \
        else np.empty((b - a, 0))
    return log.t[a:b].astype(float), u.astype(float), y.astype(float)


def check_observer(obs, log: DriveLog, *, rows: int = 2000, k: int | None = None,
                   rtol: float = 1e-9, atol: float = 1e-12) -> ObserverCheck:
    """Run the protocol checks (module docstring) of ``obs`` on ``log``; never raises for a
    failed check (:meth:`ObserverCheck.raise_if_failed` does). ``k``: the last sample kept in
    the causality check (default: the middle of the data); ``rtol``, ``atol``: tolerance of
    compiled against readable (rounding: the two loops may sum in another order)."""
    rep = ObserverCheck(type(obs).__name__)
    add = rep.results.append
    names = tuple(obs.input_names) + tuple(obs.output_names)
    bad = [c for c in names if not is_log_column(c)]
    missing = [c for c in names if c not in bad and not log.has(c)]
    sbad = [c for c in obs.state_names if not is_log_column(c)]
    add(("names and units", not (bad or missing or sbad),
         "inputs/outputs are log columns present in the log, states named <quantity>_<unit>"
         if not (bad or missing or sbad) else
         f"not <quantity>_<unit>: {bad + sbad}; missing in the log: {missing}"))
    if bad or missing:
        return rep
    t, u, y = _data(obs, log, rows)
    n = len(obs.state_names)
    try:
        z = np.asarray(obs.initial_state(t, u, y), float)
        e = np.asarray(obs.estimate(z), float)
        b = obs.bounds(z)
        problems = []
        if z.ndim != 1:
            problems.append(f"initial_state has shape {z.shape}, expected 1-D")
        if e.shape != (n,):
            problems.append(f"estimate(z) has shape {e.shape}, expected ({n},)")
        if b is not None:
            lo, hi = (np.asarray(v, float) for v in b)
            if lo.shape != (n,) or hi.shape != (n,) or np.any(lo > hi):
                problems.append(f"bounds(z) shapes {lo.shape}, {hi.shape} or lo > hi")
        tr = obs.run(t, u, y)
        if not isinstance(tr, Trajectory):
            problems.append(f"run returned {type(tr).__name__}, expected a Trajectory")
        elif tr.x.shape != (len(t), n) or tuple(tr.names) != tuple(obs.state_names):
            problems.append(f"run gave x {tr.x.shape} named {tr.names}, expected "
                            f"({len(t)}, {n}) named {tuple(obs.state_names)}")
        elif not np.all(np.isfinite(tr.x)):
            problems.append(f"run gave a non-finite estimate from row "
                            f"{int(np.argmax(~np.all(np.isfinite(tr.x), axis=1)))}")
    except Exception as exc:   # noqa: BLE001 - reported as the failed check
        add(("shapes", False, f"{type(exc).__name__}: {exc}"))
        return rep
    add(("shapes", not problems, "; ".join(problems) or
         f"state 1-D, estimate ({n},), run (N, n) = ({len(t)}, {n}), finite"))
    if problems:
        return rep
    rd = run_readable(obs, t, u, y)
    default = type(obs).run is ObserverBase.run
    diff = float(np.max(np.abs(rd.x - tr.x) / (atol + rtol * np.abs(rd.x)))) if len(t) else 0.0
    add(("compiled equals readable", diff <= 1.0,
         "run is the default readable loop: nothing to compare" if default and diff <= 1.0 else
         f"largest difference {diff:.3g} x tolerance (rtol {rtol:g}, atol {atol:g})"))
    k = len(t) // 2 if k is None else int(k)
    u2, y2 = u.copy(), y.copy()
    u2[k + 1:] = u2[k + 1:] * 1.5 + 0.1
    y2[k + 1:] = y2[k + 1:] * -0.5 + 0.05
    a, c = obs.run(t, u2, y2), run_readable(obs, t, u2, y2)
    same = np.array_equal(a.x[:k + 1], tr.x[:k + 1]) and np.array_equal(c.x[:k + 1],
                                                                          rd.x[:k + 1])
    add(("causality", same, f"estimates up to sample {k} unchanged when later samples change"
         if same else f"an estimate at or before sample {k} changed when only later samples "
         "changed: the observer reads the future"))
    return rep
