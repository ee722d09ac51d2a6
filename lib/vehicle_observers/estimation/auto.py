"""``auto``: a causal choice among the registered estimators, sample by sample, from the
measured channels only.

Candidates (:func:`candidates`): the registered causal estimators that are not baselines,
apply to the log (their columns and vehicle keys), give ``v_y`` and ``r`` and run per sample
without an LMI design (:data:`CANDIDATES`; ``candidates=`` overrides). Each is run on the
whole log; the output at sample ``k`` is decided by the candidates' **running
measured-channel scores** up to ``k - 1`` (causal: the score at ``k`` never decides sample
``k``), by one of two rules (:data:`RULES`, option ``rule``):

* ``select`` (default): the estimate of the candidate with the lowest score; a candidate
  replaces the current one only when its score is below ``(1 - HYSTERESIS)`` times the
  current's (no chattering between near-equal candidates); ``vy_std_mps`` the chosen
  candidate's calibrated std;
* ``mix``: IMM-style model probabilities (:func:`weights`: the likelihood of the scores with
  a fixed share, Blom & Bar-Shalom 1988) and the weighted mean of the estimates, with the
  mixture's std (:func:`combine`).

Score (a running model-selection rule on normalised residuals, the prequential principle
of Dawid 1984, J. R. Stat. Soc. A 147): for each candidate, the lateral acceleration of the
vehicle file's single-track model at its estimate against the measured ``a_y`` (less a slow
offset, :data:`vehicle_observers.estimation.calibration.BIAS_TAU_S`) and its yaw rate
against the measured one, each squared and divided by the channel's running white-noise
variance (:func:`running_noise_var`, causal), summed, and averaged causally with the time
constant :data:`TAU_S`. ``info["auto_line"]`` says which candidate was used on what share of
the rows, and the scores that decided.

What it cannot do: a stiffness error moves ``v_y`` without changing ``r`` and ``a_y``
(:mod:`vehicle_observers.estimation.calibration`), so the score cannot rank candidates by
that error, and a candidate with more model terms (``adaptive-ekf``) fits the measured
channels better whether or not its ``v_y`` is better; the benchmark compares ``auto`` with
every fixed choice.
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
#: time constant [s] of the running white-noise variance the residuals are divided by
NOISE_TAU_S = 30.0
#: correlation time [s] of the normalised residuals: samples closer than this count as one
#: in the likelihood of :func:`weights` (the yaw mode's transients last about a second)
CORR_S = 1.0
#: share of every candidate kept in the weights whatever the evidence (fixed share)
SHARE = 0.02
#: rules: "select" (the lowest running score with hysteresis, :func:`choose`) or "mix"
#: (the estimates averaged with the weights of :func:`weights`)
RULES = ("select", "mix")
#: the default rule
RULE = "select"


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


def running_noise_var(x, t, tau: float = NOISE_TAU_S) -> np.ndarray:
    """Causal running variance of the white part of a channel ``x`` (N,): the exponential
    mean (time constant ``tau`` [s]) of its squared second differences over 6 (a white noise
    of variance ``s^2`` has ``E[(x_{k+1} - 2 x_k + x_{k-1})^2] = 6 s^2``; the whole-log
    :func:`~vehicle_observers.data.identification.white_noise_std` is its robust, non-causal
    twin). Row ``k`` reads rows ``<= k``."""
    x = np.nan_to_num(np.asarray(x, float))
    d2 = np.zeros(len(x))
    if len(x) > 2:
        d2[2:] = (x[2:] - 2 * x[1:-1] + x[:-2]) ** 2 / 6.0
        d2[:2] = d2[2]
    return np.maximum(CAL._ewm(d2, t, tau), 1e-12)


def scores(vy, r, log: DriveLog, vehicle) -> np.ndarray:
    """Running measured-channel score (module docstring) of one estimate (N,). Causal: the
    score at row ``k`` reads rows ``<= k`` of the estimate and of the measured channels."""
    s = (np.nan_to_num(log.yaw_rate - r)) ** 2 / running_noise_var(log.yaw_rate, log.t)
    if log.ay is not None:
        res = np.nan_to_num(log.ay - CAL.model_ay(vy, r, log, vehicle))
        res = res - CAL._ewm(res, log.t, CAL.BIAS_TAU_S)
        s = s + res ** 2 / running_noise_var(log.ay, log.t)
    return CAL._ewm(s, log.t, TAU_S)


def weights(S: np.ndarray, t: np.ndarray, share: float = SHARE) -> np.ndarray:
    """IMM-style model probabilities (N, n) from the running scores ``S`` (N, n): row ``k``
    is ``softmax(-0.5 n_eff (S[k-1] - min S[k-1]))`` mixed with the uniform share ``share``
    (the Markov switching of an IMM, Blom & Bar-Shalom 1988, IEEE TAC 33(8); the "fixed share"
    of Herbster & Warmuth 1998, Machine Learning 32), ``n_eff = TAU_S / CORR_S`` the
    independent samples the running mean stands for (a mean of normalised squared residuals
    times the samples it averages is the log-likelihood up to a constant). Row 0 is
    uniform. Causal: row ``k`` reads ``S`` up to ``k - 1``."""
    N, n = S.shape
    n_eff = TAU_S / CORR_S
    prev = np.vstack([np.zeros((1, n)), S[:-1]])
    z = -0.5 * n_eff * (prev - prev.min(axis=1, keepdims=True))
    w = np.exp(z)
    w /= w.sum(axis=1, keepdims=True)
    return (1.0 - share) * w + share / n


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


def combine(cols: list[dict], S: np.ndarray, t: np.ndarray, rule: str) -> tuple[dict, np.ndarray]:
    """The output columns ``vy_mps``, ``yaw_rate_radps``, ``vy_std_mps`` (N,) of the
    candidates' columns ``cols`` under ``rule`` (:data:`RULES`) from their running scores
    ``S`` (N, n), and the weights (N, n) used (0/1 for "select"). "mix": the weighted mean
    and the mixture's std ``sqrt(sum w (std^2 + (v_y - mean)^2))`` (the IMM's combined
    covariance)."""
    if rule == "select":
        ch = choose(S)
        W = np.zeros_like(S)
        W[np.arange(len(ch)), ch] = 1.0
    elif rule == "mix":
        W = weights(S, t)
    else:
        from vehicle_observers.core.errors import ObserverArgumentError

        raise ObserverArgumentError(f"auto: rule must be one of {', '.join(RULES)}, got "
                                    f"{rule!r}")
    out = {}
    for key in ("vy_mps", "yaw_rate_radps"):
        out[key] = np.sum(W * np.column_stack([c[key] for c in cols]), axis=1)
    if all("vy_std_mps" in c for c in cols):
        V = np.column_stack([c["vy_mps"] for c in cols])
        Sd = np.column_stack([c["vy_std_mps"] for c in cols])
        out["vy_std_mps"] = np.sqrt(np.sum(W * (Sd ** 2 + (V - out["vy_mps"][:, None]) ** 2),
                                           axis=1))
    return out, W


@estimator("auto", "causal choice among ekf, adaptive-ekf and mbds-kf by a running score of "
           "the measured-channel residuals (r and a_y): the lowest with hysteresis "
           "(rule=select) or their IMM-style likelihood weights (rule=mix)",
           optional_columns=("ay_mps2",), paper="this library")
def run_auto(log: DriveLog, vehicle, progress=None, max_gap=segments.MAX_GAP_S,
             candidates_=None, cache: bool = False, rule: str = RULE, **opts):
    """``candidates_``: names to choose among (default :data:`CANDIDATES`); ``rule``: one of
    :data:`RULES`."""
    if rule not in RULES:
        from vehicle_observers.core.errors import ObserverArgumentError

        raise ObserverArgumentError(f"auto: rule must be one of {', '.join(RULES)}, got "
                                    f"{rule!r}")
    names = candidates(log, vehicle, candidates_)
    if not names:
        from vehicle_observers.core.errors import RegistryError

        raise RegistryError("auto: no candidate estimator applies to this log")
    specs = available()
    runs = [specs[n].run(log, vehicle, max_gap=max_gap, cache=cache, **opts) for n in names]
    cols = [r.columns for r in runs]
    S = np.column_stack([scores(c["vy_mps"], c["yaw_rate_radps"], log, vehicle) for c in cols])
    out, W = combine(cols, S, log.t, rule)
    ch = np.argmax(W, axis=1)
    out["beta_rad"] = np.arctan2(out["vy_mps"], log.vx)
    low = np.all(np.column_stack([r.flags["low_speed"] for r in runs]), axis=1)
    out["low_speed"] = low
    out["reinit"] = runs[0].flags["reinit"]
    share = {n: float(np.mean(ch == i)) for i, n in enumerate(names)}
    mean_w = {n: float(np.mean(W[:, i])) for i, n in enumerate(names)}
    switches = int(np.sum(np.diff(ch) != 0))
    last = S[-1]
    why = ", ".join(f"{n} {v:.3g}" for n, v in zip(names, last))
    how = ("the lowest running score, replaced only when another is "
           f"{100 * HYSTERESIS:g} % lower" if rule == "select" else
           f"likelihood weights of the running scores (IMM-style, {100 * SHARE:g} % fixed "
           "share), estimates averaged")
    line = (f"auto ({rule}) among {', '.join(names)} by the running score of the measured "
            f"channels (r, a_y residuals of the vehicle model at each estimate over "
            f"{TAU_S:g} s; {how}): "
            + ", ".join(f"{n} {100 * v:.0f} %" for n, v in share.items() if v > 0)
            + " of the rows" + ("" if rule == "select" else " with the largest weight; mean "
                                "weights " + ", ".join(f"{n} {v:.2f}" for n, v in
                                                        mean_w.items()))
            + f", {switches} switch(es); scores at the end (lower is better): {why}")
    info = {"auto_candidates": names, "auto_share": share, "auto_switches": switches,
            "auto_line": line, "auto_choice": ch, "auto_weights": W, "auto_rule": rule}
    tr = Trajectory.from_columns(log.t, out, seconds=sum(r.seconds for r in runs),
                                 design_seconds=sum(r.design_seconds for r in runs),
                                 causal=True, estimator="auto", info=info)
    # the candidates' stds are calibrated already: only the verdict is added
    tr.info.update(CAL.verdict_info(out["vy_mps"], out["vy_std_mps"], log, vehicle, low))
    tr.info["uncertainty"] = ("the chosen candidate's calibrated std" if rule == "select" else
                              "the mixture of the candidates' calibrated stds")
    return tr
