"""``auto``: a causal choice among the registered estimators, sample by sample, from the
measured channels only.

Candidates (:func:`candidates`): the registered causal estimators that are not baselines,
apply to the log (their columns and vehicle keys), give ``v_y`` and ``r`` and run per sample
without an LMI design (:data:`CANDIDATES`; ``candidates=`` overrides). Each is run on the
whole log; at sample ``k`` the estimate of the candidate with the smallest **running
measured-channel score** up to ``k - 1`` is output (causal: the score at ``k`` never decides
sample ``k``).

Score (a running model-selection rule on normalised residuals, the prequential principle
of Dawid 1984, J. R. Stat. Soc. A 147): for each candidate, the lateral acceleration of the
vehicle file's single-track model at its estimate against the measured ``a_y`` (less a slow
offset, :data:`vehicle_observers.estimation.calibration.BIAS_TAU_S`) and its yaw rate
against the measured one, each squared and divided by the channel's white-noise variance
(:func:`~vehicle_observers.data.identification.white_noise_std`), summed, and averaged
causally with the time constant :data:`TAU_S`. A candidate replaces the current one only
when its score is below ``(1 - HYSTERESIS)`` times the current's (no chattering between
near-equal candidates). The output's ``vy_std_mps`` is the chosen candidate's calibrated
std; ``info["auto_line"]`` says which candidate was used on what share of the rows and why.

What it cannot do: a stiffness error moves ``v_y`` without changing ``r`` and ``a_y``
(:mod:`vehicle_observers.estimation.calibration`), so the score cannot rank candidates by
that error; the benchmark compares ``auto`` with every fixed choice.
"""

from __future__ import annotations

import numpy as np

from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import calibration as CAL
from vehicle_observers.estimation import segments
from vehicle_observers.estimation.registry import available, estimator

#: candidates by default, in order of preference on ties (filters without an LMI design)
CANDIDATES = ("ekf", "adaptive-ekf", "mbds-kf")
#: time constant [s] of the running score (chosen here: long enough that a corner's
#: transient does not switch, short enough to follow a change of track section)
TAU_S = 60.0
#: relative margin a candidate's score must beat the current one's by to take over
HYSTERESIS = 0.1


def candidates(log: DriveLog, vehicle, names=None) -> list[str]:
    """The candidates of :data:`CANDIDATES` (or ``names``) that are registered, causal and
    apply to ``log`` and ``vehicle``."""
    specs = available()
    out = []
    for n in (CANDIDATES if names is None else names):
        s = specs.get(n)
        if s is None or not s.causal or n == "auto":
            continue
        try:
            s.check(log, vehicle)
        except Exception:  # noqa: BLE001 - not applicable to this log
            continue
        out.append(n)
    return out


def scores(vy, r, log: DriveLog, vehicle) -> np.ndarray:
    """Running measured-channel score (module docstring) of one estimate (N,)."""
    from vehicle_observers.data.identification import white_noise_std

    R_r = max(white_noise_std(log.yaw_rate) ** 2, 1e-12)
    s = (np.nan_to_num(log.yaw_rate - r)) ** 2 / R_r
    if log.ay is not None:
        res = np.nan_to_num(log.ay - CAL.model_ay(vy, r, log, vehicle))
        res = res - CAL._ewm(res, log.t, CAL.BIAS_TAU_S)
        s = s + res ** 2 / max(white_noise_std(log.ay) ** 2, 1e-12)
    return CAL._ewm(s, log.t, TAU_S)


def choose(S: np.ndarray, hysteresis: float = HYSTERESIS) -> np.ndarray:
    """Causal choice (N,) of a column of the scores ``S`` (N, n): row 0 takes column 0 (the
    first candidate); row ``k`` keeps the previous choice unless another column's score at
    ``k - 1`` is below ``(1 - hysteresis)`` times the current's."""
    N = S.shape[0]
    ch = np.zeros(N, int)
    cur = 0
    for k in range(1, N):
        j = int(np.argmin(S[k - 1]))
        if j != cur and S[k - 1, j] < (1.0 - hysteresis) * S[k - 1, cur]:
            cur = j
        ch[k] = cur
    return ch


@estimator("auto", "causal choice among ekf, adaptive-ekf and mbds-kf per sample by a running "
           "score of the measured-channel residuals (r and a_y), with hysteresis",
           optional_columns=("ay_mps2",), paper="this library")
def run_auto(log: DriveLog, vehicle, progress=None, max_gap=segments.MAX_GAP_S,
             candidates_=None, cache: bool = False, **opts):
    """``candidates_``: names to choose among (default :data:`CANDIDATES`)."""
    names = candidates(log, vehicle, candidates_)
    if not names:
        from vehicle_observers.core.errors import RegistryError

        raise RegistryError("auto: no candidate estimator applies to this log")
    specs = available()
    runs = [specs[n].run(log, vehicle, max_gap=max_gap, cache=cache, **opts) for n in names]
    cols = [r.columns for r in runs]
    S = np.column_stack([scores(c["vy_mps"], c["yaw_rate_radps"], log, vehicle) for c in cols])
    ch = choose(S)
    rows = np.arange(len(log))
    out = {}
    for key in ("vy_mps", "yaw_rate_radps", "vy_std_mps"):
        if all(key in c for c in cols):
            out[key] = np.column_stack([c[key] for c in cols])[rows, ch]
    out["beta_rad"] = np.arctan2(out["vy_mps"], log.vx)
    low = np.all(np.column_stack([r.flags["low_speed"] for r in runs]), axis=1)
    out["low_speed"] = low
    out["reinit"] = runs[0].flags["reinit"]
    share = {n: float(np.mean(ch == i)) for i, n in enumerate(names)}
    switches = int(np.sum(np.diff(ch) != 0))
    first = int(np.argmin(S[min(len(log) - 1, int(TAU_S / max(log.dt, 1e-9)))]))
    line = (f"auto chose among {', '.join(names)} by the running score of the measured "
            f"channels (r, a_y residuals of the vehicle model at each estimate; {TAU_S:g} s "
            f"average): " + ", ".join(f"{n} {100 * v:.0f} %" for n, v in share.items()
                                      if v > 0)
            + f" of the rows, {switches} switch(es); lowest score after the first "
              f"{TAU_S:g} s: {names[first]}")
    info = {"auto_candidates": names, "auto_share": share, "auto_switches": switches,
            "auto_line": line, "auto_choice": ch}
    tr = Trajectory.from_columns(log.t, out, seconds=sum(r.seconds for r in runs),
                                 design_seconds=sum(r.design_seconds for r in runs),
                                 causal=True, estimator="auto", info=info)
    # the chosen candidates' stds are calibrated already: only the verdict is added
    tr.info.update(CAL.verdict_info(out["vy_mps"], out["vy_std_mps"], log, vehicle, low))
    tr.info["uncertainty"] = "the chosen candidate's calibrated std"
    return tr
