"""Calibrated ``v_y`` uncertainty for every estimator, from the vehicle file and the measured
channels only (the reference ``v_y`` is never read).

A filter's own covariance describes the noise it was tuned for, not the error of its model:
on a car that is not exactly its vehicle file the EKF reports a ``v_y`` std of a millimetre
per second while its error is several centimetres (mean NEES in the thousands). The error
that the measured channels cannot show (a stiffness error moves ``v_y`` and leaves ``r`` and
``a_y`` fitted) can only be bounded by what the vehicle file declares; the error they do show
is measured on them. The calibrated variance of ``v_y`` [(m/s)^2] at sample ``k`` is the sum
of four terms (:func:`calibrated_std`):

1. **Filter**: the estimator's own variance ``P_vy`` (0 for estimators without one).
2. **Consider term** (Schmidt-Kalman "consider" analysis of an uncertain parameter: Schmidt
   1966; Woodbury, Tapley et al., *Statistical Orbit Determination*, 2004, Sec. 6.3): with
   ``a_y`` and ``r`` fitted, the rear axle's lateral force is fixed by the moment balance and
   ``v_y = a_r r - v_x alpha_r`` with ``alpha_r = F_r / C_r``; a relative error ``eps`` of the
   rear compliance ``1 / C_r`` moves ``v_y`` by ``v_x alpha_r eps``, ``alpha_r`` the
   estimate's own rear slip ``-(v_y - a_r r) / v_x``. The variance is
   ``(v_x alpha_r)^2 E[eps^2]`` with ``E[eps^2] = (c_r - 1)^2 + P_rr`` under the **posterior**
   of the axle compliance ratios ``c = C_nominal / C_true`` given the measured channels
   (:func:`compliance_posterior`): Bayesian linear regression (Gelman et al., *Bayesian Data
   Analysis*, 3rd ed., 2013, Sec. 14.2) of the kinematic identity
   ``delta - L r / v_x = alpha_f - alpha_r`` on the slips the vehicle file's tyres need for the
   axle forces measured by ``a_y`` and ``dr/dt`` (``F_f = (m a_y a_r + I_z dr/dt) / L``,
   ``F_r = (m a_y a_f - I_z dr/dt) / L``), with exponential forgetting (recursive least
   squares, Ljung & Soederstroem, *Theory and Practice of Recursive Identification*, 1983,
   Sec. 2.6) and the vehicle file's stiffness box ``uncertainty.stiffness_rel`` taken
   uniform as the prior (std ``rel / sqrt(3)``; :data:`DEFAULT_REL` when the file declares
   none). Where the data fix the compliances (transients: ``dr/dt`` separates the axles)
   the term is the mismatch the measured channels show; where they do not (steady cornering
   fixes only the understeer combination; no ``a_y`` channel) it stays the prior box.
   Skipped for filters that already carry the box in their covariance (``consider=False``:
   ``adaptive-ekf``'s Schmidt states).
3. **Residual term** (covariance matching on the measured-channel residuals, Mehra 1970,
   IEEE TAC 15(2); the windowed estimate of Mohamed & Schwarz 1999, J. Geodesy 73): the
   lateral acceleration the vehicle file's tyres give at the estimate,
   ``a_y,model = (F_f(alpha_f) + F_r(alpha_r)) / m``, against the measured ``a_y``. Its
   residual, less a slow offset (mounting, bias: exponential mean over :data:`BIAS_TAU_S`),
   has a running power (exponential mean over :data:`RES_TAU_S`, causal) above the
   channel's white-noise variance that the model does not explain; mapped to ``v_y`` by the
   model's sensitivity ``d a_y / d v_y = -(C_f + C_r) / (m v_x)``:
   ``(m v_x / (C_f + C_r))^2 max(0, power - R_ay)``. Logs without ``a_y``: 0.
4. **Sideslip floor** ``(v_x tan BETA_FLOOR)^2``: the constant sideslip offset no lateral model
   here holds (wheel alignment, ply steer) and no measured channel shows
   (:data:`BETA_FLOOR`, 0.1 deg).

The four are independent error sources, so their variances add. Nothing here is fitted to a
reference column: the box and the floor are declared, the residual term is measured.

A std that covers ``v_y = 0`` nearly always makes the estimate uninformative
(:func:`zero_covered`): the identifiability verdict of
:func:`vehicle_observers.estimation.selection.verdict` is computed on this std
(:func:`verdict`).
"""

from __future__ import annotations

import math

import numpy as np

from vehicle_observers.core.metrics import coverage_2sigma, mean_nees
from vehicle_observers.data.logs import DriveLog

#: constant-sideslip floor of the uncertainty [rad] (0.1 deg: a wheel-alignment tolerance)
BETA_FLOOR = math.radians(0.1)
#: the estimate is "informative" when RMS(v_y) >= this x RMS(v_y std)
MIN_SIGNAL_TO_STD = 1.0
#: stiffness box half-width assumed when the vehicle file declares none (a road tyre's
#: cornering stiffness varies by about +-10 % with load, pressure and wear)
DEFAULT_REL = 0.10
#: time constant [s] of the residual's running power (a few yaw-mode time constants)
RES_TAU_S = 1.0
#: time constant [s] of the slow a_y residual offset removed before its power is taken
BIAS_TAU_S = 10.0
#: share of the scored rows whose 2-sigma band contains 0 above which the std is
#: uninformative (chosen here: 0.95, a band that contains 0 as often as a consistent band
#: contains the truth)
ZERO_COVERED = 0.95
#: seconds at the start of a log left out of the verdict (initial covariance transient; the
#: benchmark scores from t > 1 s too)
SETTLE_S = 1.0
#: smallest |v_x| [m/s] the sensitivities divide by
VX_MIN = 1.0
#: time constant [s] of the causal low-pass applied to every channel before the axle forces
#: are formed (``dr/dt`` of a 100 Hz yaw rate with 0.002 rad/s noise is otherwise noise;
#: 0.1 s keeps the yaw mode, whose time constants are 0.1-0.5 s at road speeds)
ID_SMOOTH_S = 0.1
#: forgetting time constant [s] of the compliance regression (a stiffness mismatch is a
#: property of the car and its tyres: it changes over minutes, with temperature and wear)
ID_TAU_S = 60.0
#: correlation time [s] of the regression's residuals: samples closer than this count as one
#: (the yaw mode's transients, hence the model error they leave, last about a second)
ID_CORR_S = 1.0
#: independent samples (:data:`ID_CORR_S` apart) the regression needs before it moves from the
#: prior (with fewer, its residual mean square is fitted to the few rows it has)
ID_MIN_INDEP = 5.0
#: speed [m/s] below which a row does not enter the regression (the slips divide by v_x)
ID_VX_MIN = 5.0
#: prior std [rad] of the regression's intercept (a steering or a_y offset; 1 deg)
ID_OFFSET_PRIOR = math.radians(1.0)
#: rows per posterior evaluation are thinned to at most this rate [Hz] (held in between)
ID_RATE_HZ = 10.0
#: rows where either tyre's local slope at the estimate is below this share of its zero-slip
#: slope do not enter the regression (near and past the peak the nominal inverse is
#: ill-conditioned or undefined: a Newton step there gave negative compliances on a lap)
ID_MIN_SLOPE = 0.5


def _ewm(x: np.ndarray, t: np.ndarray, tau: float) -> np.ndarray:
    """Causal exponential mean of ``x`` with time constant ``tau`` [s] on the grid ``t``,
    started at ``x[0]``."""
    from scipy.signal import lfilter

    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    a = math.exp(-dt / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y


def model_ay(vy, r, log: DriveLog, vehicle) -> np.ndarray:
    """Lateral acceleration [m/s^2] of the vehicle file's single-track model at the estimate
    ``vy`` [m/s], ``r`` [rad/s] (N,): ``(F_f + F_r) / m`` at the small-angle slips
    (Yacine 2015 eqs. (1), (4))."""
    p = vehicle.params
    vx = np.maximum(np.abs(log.vx), VX_MIN)
    a_f = log.delta - (vy + p.a_f * r) / vx
    a_r = -(vy - p.a_r * r) / vx
    return (p.tire_f.force(a_f) + p.tire_r.force(a_r)) / p.m


def residual_variance(vy, r, log: DriveLog, vehicle) -> np.ndarray:
    """Term 3 of the module docstring [(m/s)^2], (N,); zeros without an a_y channel."""
    from vehicle_observers.data.identification import white_noise_std

    if log.ay is None or len(log) < 5:
        return np.zeros(len(log))
    p = vehicle.params
    res = log.ay - model_ay(vy, r, log, vehicle)
    res = np.where(np.isfinite(res), res, 0.0)
    res = res - _ewm(res, log.t, BIAS_TAU_S)
    power = _ewm(res ** 2, log.t, RES_TAU_S)
    R_ay = white_noise_std(log.ay) ** 2
    C = float(p.tire_f.cornering_stiffness + p.tire_r.cornering_stiffness)
    gain = p.m * np.maximum(np.abs(log.vx), VX_MIN) / C
    return gain ** 2 * np.maximum(power - R_ay, 0.0)


def _local_inverse(tyre, alpha, F) -> tuple[np.ndarray, np.ndarray]:
    """The slip [rad] the tyre ``tyre`` needs for the force ``F`` [N], one Newton step from
    ``alpha`` [rad] (N,) on its curve, and where it is usable: the local slope at least
    :data:`ID_MIN_SLOPE` of the zero-slip slope (N,) bool."""
    C0 = float(tyre.cornering_stiffness)
    h = 1e-4
    slope = (tyre.force(alpha + h) - tyre.force(alpha - h)) / (2 * h)
    ok = slope >= ID_MIN_SLOPE * C0
    slope = np.maximum(slope, ID_MIN_SLOPE * C0)
    return alpha + (F - tyre.force(alpha)) / slope, ok


def measured_axle_forces(log: DriveLog, vehicle, tau: float = ID_SMOOTH_S):
    """Axle forces [N] (N,) from the measured channels only, ``F_f = (m a_y a_r + I_z dr/dt)
    / L`` and ``F_r = (m a_y a_f - I_z dr/dt) / L`` (force and moment balance of the single
    track, Yacine 2015 eq. (1)), on ``a_y`` and the yaw rate low-passed causally with ``tau``
    [s] (``dr/dt`` by backward differences of the low-passed yaw rate). ``None`` without an
    a_y channel."""
    if log.ay is None:
        return None
    p = vehicle.params
    L = p.a_f + p.a_r
    ay = _ewm(np.nan_to_num(log.ay), log.t, tau)
    r = _ewm(np.nan_to_num(log.yaw_rate), log.t, tau)
    dt = np.diff(log.t, prepend=log.t[0] - (log.t[1] - log.t[0] if len(log) > 1 else 1.0))
    rd = np.diff(r, prepend=r[0]) / np.maximum(dt, 1e-9)
    return (p.m * ay * p.a_r + p.I_z * rd) / L, (p.m * ay * p.a_f - p.I_z * rd) / L


def compliance_posterior(vy, r, log: DriveLog, vehicle):
    """Running posterior of the axle compliance ratios ``c = (c_f, c_r)`` (nominal over true
    cornering stiffness; 1 = the vehicle file is right) and of an offset ``b`` [rad], from the
    measured channels and the estimate ``vy`` [m/s], ``r`` [rad/s] (N,) as the tyres'
    operating point (module docstring, term 2). Regression, per row in motion (``v_x >=``
    :data:`ID_VX_MIN`): ``delta - L r_meas / v_x = c_f phi_f - c_r phi_r + b``, ``phi`` the
    slip the file's tyre needs for the measured axle force (:func:`measured_axle_forces`,
    :func:`_local_inverse`; rows near a tyre's peak left out); every channel low-passed with
    :data:`ID_SMOOTH_S`; sums forgotten with :data:`ID_TAU_S`; noise variance the residual
    mean square at the least-squares solution (floored by the propagated sensor noise), samples
    :data:`ID_CORR_S` apart counted as independent; prior ``c ~ N(1, rel^2 / 3)`` per axle
    (the stiffness box taken uniform), ``b ~ N(0, ID_OFFSET_PRIOR^2)``. Causal: row ``k`` uses
    rows ``<= k`` (evaluated at :data:`ID_RATE_HZ`, held in between), except the sensor-noise
    floor of the residual variance (the whole log's white-noise std of ``delta`` and ``r``).

    What it can tell: the understeer combination of the two compliances is fixed by steady
    cornering, the axles apart by transients; a common scale of both on a car near neutral
    steer is seen by neither (it stays near the prior), nor is an accelerometer's roll gain
    told from a stiffness error (both scale the measured forces).

    Returns ``(mean, var)``, each (N, 3) for ``(c_f, c_r, b)``: the posterior mean and the
    posterior variances (diagonal of the covariance). Without an a_y channel: the prior."""
    from vehicle_observers.data.identification import white_noise_std

    rel = float(vehicle.uncertainty.get("stiffness_rel", DEFAULT_REL))
    N = len(log)
    prior_m = np.array([1.0, 1.0, 0.0])
    prior_v = np.array([rel ** 2 / 3.0, rel ** 2 / 3.0, ID_OFFSET_PRIOR ** 2])
    mean = np.tile(prior_m, (N, 1))
    var = np.tile(prior_v, (N, 1))
    F = measured_axle_forces(log, vehicle)
    if F is None or N < 5:
        return mean, var
    p = vehicle.params
    L = p.a_f + p.a_r
    sm = lambda x: _ewm(np.nan_to_num(np.asarray(x, float)), log.t, ID_SMOOTH_S)  # noqa: E731
    vx = sm(log.vx)
    vxs = np.maximum(np.abs(vx), VX_MIN)
    d, rm, vye, re = sm(log.delta), sm(log.yaw_rate), sm(vy), sm(r)
    a_f = d - (vye + p.a_f * re) / vxs
    a_r = -(vye - p.a_r * re) / vxs
    phi_f, ok_f = _local_inverse(p.tire_f, a_f, F[0])
    phi_r, ok_r = _local_inverse(p.tire_r, a_r, F[1])
    y = d - L * rm / vxs
    X = np.column_stack([phi_f, -phi_r, np.ones(N)])
    w = ((np.abs(vx) >= ID_VX_MIN) & ok_f & ok_r & np.all(np.isfinite(X), axis=1)
         & np.isfinite(y)).astype(float)
    X = np.where(w[:, None] > 0, X, 0.0)
    y = np.where(w > 0, y, 0.0)
    # exponentially forgotten sums (causal, from zero): W the forgotten count of the rows
    from scipy.signal import lfilter

    dt = float(np.median(np.diff(log.t)))
    lam = math.exp(-dt / ID_TAU_S)

    def fsum(x):
        return lfilter([1.0], [1.0, -lam], x)

    iu = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    S = {ij: fsum(w * X[:, ij[0]] * X[:, ij[1]]) for ij in iu}
    Sy = [fsum(w * X[:, i] * y) for i in range(3)]
    Syy = fsum(w * y * y)
    W = fsum(w)
    step = max(1, int(round(1.0 / (ID_RATE_HZ * dt))))
    # the independent samples among the rows counted
    n_indep = W * dt / ID_CORR_S
    # sensor-noise floor of the residual variance: steering and yaw-rate noise in y
    s0 = (white_noise_std(log.delta) ** 2
          + (L / max(float(np.median(vxs)), VX_MIN)) ** 2 * white_noise_std(log.yaw_rate) ** 2)
    idx = np.arange(0, N, step)
    ok = n_indep[idx] >= ID_MIN_INDEP
    k = idx[ok]
    Wk = W[k]
    A = np.empty((len(k), 3, 3))
    for (i, j) in iu:
        A[:, i, j] = A[:, j, i] = S[(i, j)][k] / Wk
    bv = np.column_stack([Sy[i][k] for i in range(3)]) / Wk[:, None]
    yy = Syy[k] / Wk
    reg = 1e-9 * np.trace(A, axis1=1, axis2=2)[:, None, None] * np.eye(3) + 1e-300
    c_ls = np.linalg.solve(A + reg, bv[..., None])[..., 0]
    res = yy - 2 * np.einsum("ki,ki->k", c_ls, bv) + np.einsum("ki,kij,kj->k", c_ls, A, c_ls)
    s2 = np.maximum(res, s0)
    info = A * (n_indep[k] / s2)[:, None, None]
    Pk = np.linalg.inv(info + np.diag(1.0 / prior_v))
    rhs = bv * (n_indep[k] / s2)[:, None] + prior_m / prior_v
    mean[k] = np.einsum("kij,kj->ki", Pk, rhs)
    var[k] = np.diagonal(Pk, axis1=1, axis2=2)
    # hold each evaluation until the next (causal)
    held = np.repeat(idx, np.diff(np.r_[idx, N]))
    return mean[held], var[held]


def consider_variance(vy, r, log: DriveLog, vehicle, posterior=None) -> np.ndarray:
    """Term 2 of the module docstring [(m/s)^2], (N,); ``posterior`` the
    :func:`compliance_posterior` when computed already."""
    mean, var = compliance_posterior(vy, r, log, vehicle) if posterior is None else posterior
    vx = np.maximum(np.abs(log.vx), VX_MIN)
    alpha_r = -(vy - vehicle.params.a_r * r) / vx
    eps2 = (mean[:, 1] - 1.0) ** 2 + var[:, 1]
    return (np.abs(log.vx) * alpha_r) ** 2 * eps2


def floor_variance(log: DriveLog) -> np.ndarray:
    """Term 4 of the module docstring [(m/s)^2], (N,)."""
    return (np.abs(log.vx) * math.tan(BETA_FLOOR)) ** 2


def calibrated_std(vy, r, log: DriveLog, vehicle, filter_std=None,
                   consider: bool = True) -> np.ndarray:
    """Calibrated ``v_y`` std [m/s] (N,) of an estimate ``vy`` [m/s], ``r`` [rad/s] (N,) on
    ``log`` with ``vehicle`` (module docstring); ``filter_std`` the estimator's own std
    (N,) or ``None``; ``consider=False`` for filters that carry the stiffness box already."""
    vy = np.asarray(vy, float)
    r = np.asarray(r, float)
    var = floor_variance(log) + residual_variance(vy, r, log, vehicle)
    if consider:
        var = var + consider_variance(vy, r, log, vehicle)
    if filter_std is not None:
        var = var + np.nan_to_num(np.asarray(filter_std, float)) ** 2
    return np.sqrt(var)


#: share of a Gaussian within 1 and 2 standard deviations: ``erf(k / sqrt(2))``
GAUSS_1SIGMA = math.erf(1.0 / math.sqrt(2.0))
GAUSS_2SIGMA = math.erf(2.0 / math.sqrt(2.0))


def coverage(err, std, mask=None) -> dict:
    """Consistency of a reported std with the errors it claims to describe: ``err`` (N,)
    the estimate minus the reference [m/s], ``std`` (N,) the reported std [m/s], over the rows
    ``mask``. Returns ``{"coverage_2sigma", "coverage_1sigma", "nees", "n"}``: the shares of
    ``|err| <= 2 std`` and ``|err| <= std`` (a consistent Gaussian std: :data:`GAUSS_2SIGMA`
    = 0.954 and :data:`GAUSS_1SIGMA` = 0.683) and the mean normalised estimation error
    squared ``mean((err / std)^2)`` (1 when consistent; Bar-Shalom, Li & Kirubarajan,
    *Estimation with Applications to Tracking and Navigation*, 2001, Sec. 5.4). An error
    spread evenly (a bias that follows the slip, not Gaussian noise) reaches NEES 1 with a
    2-sigma coverage of 1.00: the two numbers are read together."""
    e = np.asarray(err, float)
    s = np.maximum(np.asarray(std, float), 1e-12)
    m = np.ones(len(e), bool) if mask is None else np.asarray(mask, bool)
    e, s = e[m], s[m]
    if not len(e):
        return {"coverage_2sigma": float("nan"), "coverage_1sigma": float("nan"),
                "nees": float("nan"), "n": 0}
    zero = np.zeros(len(e))
    return {"coverage_2sigma": coverage_2sigma(e, s, zero),
            "coverage_1sigma": float(np.mean(np.abs(e) <= s)),
            "nees": mean_nees(e, s, zero), "n": int(len(e))}


def binomial_band(n: int, p: float = GAUSS_2SIGMA, z: float = 3.29) -> tuple[float, float]:
    """``p -+ z sqrt(p (1 - p) / n)``: where the share of ``n`` independent trials of
    probability ``p`` falls (normal approximation; ``z = 3.29``: 99.9 %)."""
    h = z * math.sqrt(p * (1.0 - p) / n)
    return p - h, p + h


def zero_covered(vy, std, mask=None) -> float:
    """Share of the rows (``mask``) whose 2-sigma band ``vy +- 2 std`` contains 0."""
    m = np.ones(len(vy), bool) if mask is None else np.asarray(mask, bool)
    return float(np.mean(np.abs(np.asarray(vy)[m]) <= 2.0 * np.asarray(std)[m])) if m.any() \
        else 1.0


def calibrate(traj, log: DriveLog, vehicle, consider: bool = True, verdict: bool = True):
    """``traj`` with ``vy_std_mps`` replaced by :func:`calibrated_std` (the estimator's own
    std kept as ``vy_std_filter_mps``), the method in ``info["uncertainty"]`` and, with
    ``verdict``, the identifiability verdict of
    :func:`vehicle_observers.estimation.selection.verdict` on the calibrated std over the
    rows in motion (``info["verdict"]``, ``info["verdict_line"]``,
    ``info["signal_to_std"]``, ``info["zero_covered"]``). Trajectories without ``vy_mps``
    and ``yaw_rate_radps`` are returned unchanged. Returns a new Trajectory."""
    from vehicle_observers.core.protocol import Trajectory

    cols = traj.columns
    if "vy_mps" not in cols or "yaw_rate_radps" not in cols:
        return traj
    own = cols.get("vy_std_mps")
    std = calibrated_std(cols["vy_mps"], cols["yaw_rate_radps"], log, vehicle, own, consider)
    new = {k: v for k, v in cols.items() if k != "vy_std_filter_mps"}
    new["vy_std_mps"] = std
    if own is not None:
        new["vy_std_filter_mps"] = own
    new.update(traj.flags)
    info = dict(traj.info)
    info["uncertainty"] = METHOD if consider else METHOD_CONSIDERED
    if verdict:
        info.update(verdict_info(cols["vy_mps"], std, log, vehicle, traj.flags.get("low_speed")))
    return Trajectory.from_columns(traj.t, new, seconds=traj.seconds,
                                   design_seconds=traj.design_seconds, causal=traj.causal,
                                   estimator=traj.estimator, info=info)


#: ``info["uncertainty"]`` of :func:`calibrate`
METHOD = ("calibrated (vehicle_observers.estimation.calibration): filter variance + "
          "stiffness-box consider term (Schmidt) + a_y residual covariance matching (Mehra "
          "1970, Mohamed & Schwarz 1999) + 0.1 deg sideslip floor")
METHOD_CONSIDERED = ("calibrated (vehicle_observers.estimation.calibration): filter variance "
                     "(stiffness box as Schmidt consider states) + a_y residual covariance "
                     "matching (Mehra 1970, Mohamed & Schwarz 1999) + 0.1 deg sideslip floor")


def verdict_info(vy, std, log: DriveLog, vehicle, low_speed=None) -> dict:
    """The identifiability verdict (:func:`vehicle_observers.estimation.selection.verdict`)
    of an estimate ``vy`` with std ``std`` (N,) over the rows not flagged ``low_speed``
    after the first :data:`SETTLE_S` seconds (the filters' initial transient), as
    ``{"verdict", "verdict_line", "signal_to_std", "zero_covered"}``."""
    mask = log.t - log.t[0] > SETTLE_S
    if low_speed is not None:
        mask &= ~np.asarray(low_speed, bool)
    if not mask.any():
        mask = None
    v = identifiability(np.asarray(vy, float), np.asarray(std, float), log, vehicle,
                        log.ay is not None, mask)
    return {"verdict": v["verdict"], "verdict_line": v["line"],
            "signal_to_std": v["signal_to_std"], "zero_covered": v["zero_covered"]}


def verdict_of(traj, log: DriveLog, vehicle) -> dict:
    """The verdict of any estimate: ``traj.info``'s when the estimator gave one, else
    :func:`verdict_info` on :func:`calibrated_std` (the estimator's own std, if any, as the
    filter term); ``{"verdict": "not assessed", ...}`` for an estimate without ``vy_mps``
    and ``yaw_rate_radps`` (nothing to check against the model, e.g. ``vy-zero``)."""
    if "verdict" in traj.info:
        return {k: traj.info[k] for k in ("verdict", "verdict_line", "signal_to_std",
                                          "zero_covered") if k in traj.info}
    cols = traj.columns
    if "vy_mps" not in cols or "yaw_rate_radps" not in cols:
        return {"verdict": "not assessed",
                "verdict_line": "not assessed: the estimate has no yaw rate to check its v_y "
                                "against the vehicle model"}
    std = calibrated_std(cols["vy_mps"], cols["yaw_rate_radps"], log, vehicle,
                         cols.get("vy_std_mps"))
    return verdict_info(cols["vy_mps"], std, log, vehicle, traj.flags.get("low_speed"))


def identifiability(vy, std, log: DriveLog, vehicle, use_ay: bool, mask=None) -> dict:
    """Identifiability verdict (:func:`vehicle_observers.estimation.selection.verdict`, whose
    module docstring states it) of an estimate ``vy`` with std ``std`` [m/s] (N,) over the
    rows ``mask``. Returns ``{"verdict", "line", "signal_to_std", "zero_covered",
    "stiffness"}``."""
    m = np.ones(len(vy), bool) if mask is None else np.asarray(mask, bool)
    sig = float(np.sqrt(np.mean(vy[m] ** 2)) / max(np.sqrt(np.mean(std[m] ** 2)), 1e-12))
    out = {"signal_to_std": sig, "stiffness": None}
    reasons = []
    if not use_ay:
        from vehicle_observers.data.identification import identify_stiffness

        p = vehicle.params
        fit = identify_stiffness(log, p.m, p.I_z, p.a_f, p.a_r, channels=("yaw_rate",),
                                 nonlinear=False)
        out["stiffness"] = bool(fit.identifiable)
        if not fit.identifiable:
            reasons.append("no a_y channel and the yaw rate alone does not identify the axle "
                           "stiffnesses")
    zc = zero_covered(vy, std, m)
    out["zero_covered"] = zc
    if sig < MIN_SIGNAL_TO_STD:
        reasons.append(f"the v_y estimate (RMS) is {sig:.2f} x its own std: it cannot be told "
                       "from v_y = 0")
    elif zc > ZERO_COVERED:
        reasons.append(f"its 2-sigma band contains v_y = 0 on {100 * zc:.1f} % of the rows "
                       f"(above {100 * ZERO_COVERED:.0f} %)")
    out["verdict"] = "uninformative" if reasons else "informative"
    out["line"] = (f"UNINFORMATIVE: {'; '.join(reasons)}; v_y = 0 is expected to do as well "
                   "on this log" if reasons else
                   f"informative: RMS v_y estimate {sig:.1f} x its std, 2-sigma band clear of "
                   f"v_y = 0 on {100 * (1 - zc):.0f} % of the rows")
    return out
