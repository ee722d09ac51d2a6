"""Seeded driving scenarios with ground truth: an emulation of the Yacine 2015 Satory run.

Yacine et al., IEEE TCST 23(2), 2015, Sec. IV, drive a 3.5 km test track at Satory
(Versailles) "with different profiles", with speeds between 0.2 and 17 m/s, and log yaw rate,
steering angle, speed and the vision outputs ``y_L, psi_L`` at 1 kHz. Those data are not
public, so :func:`emulated_satory` builds a stand-in with the same structure:

Track
    A closed 3.5 km track given by its curvature ``rho(s)`` [1/m] as a function of arc length
    ``s`` [m]: straights, clothoids (curvature linear in ``s``) and circular arcs, including
    an S-bend and a tight hairpin. The lap is two copies of one half-lap whose heading
    change is exactly ``pi``; a half-turn-symmetric path closes by construction (position and
    heading), which :func:`track_xy` lets a test check.

Speed profile
    ``v(s) = min(17 m/s, sqrt(a_y,max / |rho(s)|))``, then a forward pass with the
    acceleration limit and a backward pass with the braking limit (classic lap-time-style
    profile), starting and ending at 0.2 m/s (the paper's ``v_x^min``), with one 8 m/s
    slow section (:data:`SLOW_ZONES`) so intermediate speeds are visited too. With
    ``a_y,max = 4.8 m/s^2`` the front slip reaches about 6-7 deg in the hairpins, where the
    secant stiffness of the chosen Pacejka tyres (``yacine_2015.constants``) has fallen by
    15-20 % -- the nonlinear tyre region -- while staying inside the |alpha| <= 8 deg on
    which the TS sector bounds hold. ``s(t)`` is obtained from ``t(s) = int ds / v(s)``.

Driver
    A lane-keeping preview driver (closed loop, sampled at 1 kHz with perfect perception of
    the truth): feed-forward on the curvature previewed ``0.25 s * v_x`` ahead with the
    linear understeer gradient ``K_us``, plus pure-pursuit feedback on the lateral offset of
    the preview point ``e = y_L + (d - l_s) psi_L``, ``d = max(6 m, 0.4 s * v_x)``:
    ``delta_cmd = rho(s + 0.25 v_x) (L + K_us v_x^2) - 2 L e / d^2`` (``L = a_f + a_r``),
    followed by a first-order steering actuator (time constant 0.08 s), plus a seeded
    band-limited steering disturbance (first-order filtered white noise, 0.8 s correlation,
    0.002 rad std) so that the straights are not perfectly quiet. The lateral offset stays
    within about 0.4 m of the lane centre over the lap.

Truth
    The full nonlinear model of the paper: S1 (8) with the exact slip angles (3), Pacejka
    steady forces (7) and first-order relaxation (6) with ``r_f = r_r = 0.1 m``, cascaded
    with the vision model S2 (9) at look-ahead ``l_s = 0.5 m``. Fixed-step RK4 in numba
    (``substeps`` per 1 ms sample; the relaxation pole ``v_x / r`` reaches 170 1/s),
    inputs (``v_x``, ``rho``, steering command) held over each sample. The vehicle advances
    along the road with ``s' = v_x``, which is what (9) assumes (road heading rate
    ``v_x rho``).

Sensors (1 kHz, zero-mean Gaussian, independent, from ``np.random.default_rng(seed)``;
every standard deviation is multiplied by ``noise_scale``; ``noise_scale=0`` gives exact
samples of the truth):

==================  ==================  =====================================================
channel             std                 note
==================  ==================  =====================================================
yaw rate            0.002 rad/s         inertial unit
steering (road wh.) 2e-4 rad            optical encoder
v_x                 0.02 m/s            odometer (never below 0.05 m/s after noise)
a_y                 0.05 m/s^2          accelerometer, ``(F_f + F_r) / m``
y_L                 0.005 m             vision, optionally sample-and-hold at a frame rate
psi_L               5e-4 rad            vision, same frames as y_L
==================  ==================  =====================================================

Output: a :class:`~vehicle_observers.data.logs.DriveLog` whose standard columns hold the
*measured* channels (``yaw_rate, delta, vx, ay, yL, psiL``) and the *truth* of the
unmeasured ones (``vy, Ff, Fr, rho``); ``extra`` holds the truth of every measured channel
(``*_true``), the arc length ``s_m``, the slip angles and the steady forces.

:func:`sine_with_dwell` gives a higher-speed open-loop manoeuvre (NHTSA FMVSS 126 style
sine with dwell on a straight road) with the same truth model and sensors, for benchmarks
in the nonlinear tyre region.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import A_F, A_R, L_S, LateralParams, s1_rhs, slip_angles
from vehicle_observers.models.vehicle import load_vehicle

# ----------------------------------------------------------------- defaults ----------------
FS_HZ = 1000.0                 # sensor / log rate of the paper (Ts = 0.001 s)
VX_START = 0.2                 # m/s, paper's v_x^min
VX_MAX = 17.0                  # m/s, paper's v_x^max
AY_MAX = 4.8                   # m/s^2, speed-profile lateral acceleration limit
AX_ACCEL = 1.5                 # m/s^2, acceleration limit
AX_BRAKE = 3.0                 # m/s^2, braking limit
PREVIEW_TIME = 0.4             # s, feedback preview (pure pursuit distance / v_x)
PREVIEW_MIN = 6.0              # m
FF_PREVIEW_TIME = 0.25        # s, curvature feed-forward preview
SLOW_ZONES = ((2070.0, 2260.0, 8.0),)  # (s0, s1, v_max): a slow section in the 2nd half
STEER_TAU = 0.08               # s, steering actuator time constant
STEER_DIST_STD = 0.002         # rad, driver steering disturbance std
STEER_DIST_TC = 0.8            # s, its correlation time

#: sensor noise standard deviations at ``noise_scale = 1`` (SI units)
NOISE_STD = {"yaw_rate": 0.002, "delta": 2e-4, "vx": 0.02, "ay": 0.05, "yL": 0.005,
             "psiL": 5e-4}


def _default_params() -> LateralParams:
    """The paper's car: the shipped vehicle file ``yacine2015`` (equal to
    ``vehicle_observers_papers.yacine_2015.constants.params``; a test checks it)."""
    return load_vehicle("yacine2015").params


# ----------------------------------------------------------------- track -------------------
@dataclass(frozen=True)
class Track:
    """Piecewise-linear curvature ``rho(s)``: knots ``s_knots`` [m], values ``rho_knots`` [1/m].

    Straights and arcs are constant pieces, clothoids linear ones (a piece of zero length is a
    curvature jump). ``length`` = lap length [m].
    """

    s_knots: np.ndarray
    rho_knots: np.ndarray
    name: str = "track"

    @property
    def length(self) -> float:
        return float(self.s_knots[-1])

    def rho(self, s) -> np.ndarray:
        """Curvature at arc length ``s`` (any shape), wrapped modulo the lap length."""
        s = np.mod(np.asarray(s, dtype=float), self.length)
        return np.interp(s, self.s_knots, self.rho_knots)

    def heading_change(self) -> float:
        """Total heading change over a lap, ``int rho ds`` [rad] (exact for linear pieces)."""
        return float(np.trapezoid(self.rho_knots, self.s_knots))


def _build(pieces) -> tuple[np.ndarray, np.ndarray]:
    """pieces: list of (length, rho_start, rho_end) -> knots (with duplicates at jumps)."""
    s, r = [0.0], [pieces[0][1]]
    for L, r0, r1 in pieces:
        if r0 != r[-1]:
            s.append(s[-1])
            r.append(r0)
        s.append(s[-1] + L)
        r.append(r1)
    return np.array(s), np.array(r)


def satory_track(length: float = 3500.0) -> Track:
    """The emulated 3.5 km track (half-lap repeated twice, closed by half-turn symmetry).

    Half-lap (left curvature positive): start straight 120 m; clothoid into a left R 80 m arc;
    straight; an S-bend (right R 120 m, clothoid through zero into left R 100 m); straight; a
    left R 50 m hairpin whose arc length is solved so that the half-lap turns by exactly
    ``pi``; a closing straight whose length makes the lap ``length`` metres.
    """
    k1, k2, k3, k4 = 1 / 80.0, -1 / 120.0, 1 / 100.0, 1 / 50.0

    def half(arc_hairpin, last_straight):
        return [(120.0, 0.0, 0.0), (40.0, 0.0, k1), (60.0, k1, k1), (40.0, k1, 0.0),
                (250.0, 0.0, 0.0),
                (30.0, 0.0, k2), (60.0, k2, k2), (60.0, k2, k3), (80.0, k3, k3),
                (30.0, k3, 0.0),
                (200.0, 0.0, 0.0),
                (50.0, 0.0, k4), (arc_hairpin, k4, k4), (50.0, k4, 0.0),
                (last_straight, 0.0, 0.0)]

    s, r = _build(half(0.0, 0.0))
    turn0 = float(np.trapezoid(r, s))
    arc = (np.pi - turn0) / k4
    if arc <= 0:
        raise ValueError("track pieces already turn by more than pi")
    s, r = _build(half(arc, 0.0))
    last = length / 2 - s[-1]
    if last <= 0:
        raise ValueError(f"track pieces need {2 * s[-1]:.0f} m > requested {length} m")
    s, r = _build(half(arc, last))
    s_full = np.concatenate([s, s[1:] + s[-1]])
    r_full = np.concatenate([r, r[1:]])
    return Track(s_full, r_full, name=f"emulated Satory track ({length:.0f} m)")


def track_xy(track: Track, ds: float = 0.05):
    """Centre line ``(x, y, heading)`` [m, m, rad] by integrating ``theta' = rho``,
    ``x' = cos theta``, ``y' = sin theta`` (trapezoid on a ``ds`` grid). Arrays (N,)."""
    s = np.arange(0.0, track.length + ds / 2, ds)
    rho = track.rho(s)
    rho[-1] = track.rho_knots[-1]
    th = np.concatenate([[0.0], np.cumsum(0.5 * (rho[1:] + rho[:-1]) * np.diff(s))])
    # exact-ish position by midpoint heading per cell
    thm = 0.5 * (th[1:] + th[:-1])
    x = np.concatenate([[0.0], np.cumsum(np.cos(thm) * np.diff(s))])
    y = np.concatenate([[0.0], np.cumsum(np.sin(thm) * np.diff(s))])
    return s, x, y, th


# ----------------------------------------------------------------- speed profile ----------
def speed_profile(track: Track, ds: float = 0.05, v_max: float = VX_MAX, ay_max: float = AY_MAX,
                  ax_accel: float = AX_ACCEL, ax_brake: float = AX_BRAKE,
                  v_start: float = VX_START, v_end: float = VX_START,
                  slow_zones=SLOW_ZONES):
    """Speed ``v(s)`` [m/s] on a ``ds`` grid: curvature limit, then accel/brake passes.

    Returns ``(s, v)``, arrays (N,). The curvature limit uses the largest ``|rho|`` within
    +-5 m so the speed is already reduced when a clothoid starts; ``slow_zones`` is a list
    of ``(s0, s1, v_limit)`` speed limits (a slow section widens the covered ``v_x`` range).
    """
    s = np.arange(0.0, track.length + ds / 2, ds)
    rho = np.abs(track.rho(s))
    w = int(round(5.0 / ds))
    from numpy.lib.stride_tricks import sliding_window_view

    pad = np.pad(rho, w, mode="edge")
    rho_w = sliding_window_view(pad, 2 * w + 1).max(axis=1)
    v = np.minimum(v_max, np.sqrt(ay_max / np.maximum(rho_w, 1e-9)))
    for s0, s1, vl in slow_zones:
        v[(s >= s0) & (s <= s1)] = np.minimum(v[(s >= s0) & (s <= s1)], vl)
    v[0], v[-1] = v_start, v_end
    _passes(v, ds, ax_accel, ax_brake)
    return s, v


@njit(cache=True)
def _passes(v, ds, a_acc, a_brk):
    n = v.shape[0]
    for i in range(1, n):
        lim = np.sqrt(v[i - 1] ** 2 + 2 * a_acc * ds)
        if v[i] > lim:
            v[i] = lim
    for i in range(n - 2, -1, -1):
        lim = np.sqrt(v[i + 1] ** 2 + 2 * a_brk * ds)
        if v[i] > lim:
            v[i] = lim


def time_grid(s_grid, v_grid, fs: float = FS_HZ, t_end: float | None = None):
    """Sample ``s(t)`` and ``v_x(t)`` at ``fs`` from ``t(s) = int ds / v`` (trapezoid)."""
    t_of_s = np.concatenate([[0.0], np.cumsum(np.diff(s_grid) * 0.5 *
                                              (1 / v_grid[1:] + 1 / v_grid[:-1]))])
    T = t_of_s[-1] if t_end is None else min(t_end, t_of_s[-1])
    t = np.arange(0.0, T, 1.0 / fs)
    s = np.interp(t, t_of_s, s_grid)
    vx = np.interp(s, s_grid, v_grid)
    return t, s, vx


# ----------------------------------------------------------------- truth simulation -------
#: layout of the packed driver vector ``drv`` of :func:`_closed_loop`
DRV_PREVIEW_TIME, DRV_PREVIEW_MIN, DRV_KUS, DRV_STEER_TAU, DRV_FF_PREVIEW = range(5)
#: state of the truth simulation: S1 (8) ``[v_y, r, F_f, F_r]``, S2 (9) ``[psi_L, y_L]``,
#: the actuated steering ``delta``
X_VY, X_R, X_FF, X_FR, X_PSIL, X_YL, X_DELTA = range(7)


@njit(cache=True)
def _rhs(X, dcmd, vx, rho, P, tau_s, out, exact=True):
    """S1 (8) with slip (3) (``exact``) or (4) and Pacejka forces (7) (:func:`lateral.s1_rhs`),
    the vision model S2 (9) and the first-order steering actuator towards ``dcmd``."""
    s1_rhs(X, X[X_DELTA], vx, P, exact, True, out)                    # eqs. (3)/(4), (7), (8)
    vy, r, psiL = X[X_VY], X[X_R], X[X_PSIL]
    ls = P[L_S]
    out[X_PSIL] = r - vx * rho                                        # eq. (9)
    out[X_YL] = vy + vx * psiL + ls * (r - vx * rho)
    out[X_DELTA] = (dcmd - X[X_DELTA]) / tau_s


@njit(cache=True)
def _closed_loop(t, s, vx, track_s, track_rho, lap, P, dist, drv, substeps, X0):
    """Closed-loop RK4 run; ``drv`` packed by the ``DRV_*`` indices (preview time [s],
    preview minimum [m], understeer gradient K_us, steering time constant [s], curvature
    feed-forward preview [s])."""
    N = t.shape[0]
    out = np.empty((N, 8))    # vy r Ff Fr psiL yL delta delta_cmd
    x = X0.copy()
    k1 = np.empty(7)
    k2 = np.empty(7)
    k3 = np.empty(7)
    k4 = np.empty(7)
    tmp = np.empty(7)
    L = P[A_F] + P[A_R]
    ls = P[L_S]
    dt = t[1] - t[0]
    h = dt / substeps
    for k in range(N):
        v = vx[k]
        d = max(drv[DRV_PREVIEW_MIN], drv[DRV_PREVIEW_TIME] * v)
        sp = (s[k] + drv[DRV_FF_PREVIEW] * v) % lap
        rho_prev = np.interp(sp, track_s, track_rho)
        rho = np.interp(s[k] % lap, track_s, track_rho)
        e = x[X_YL] + (d - ls) * x[X_PSIL]
        dcmd = rho_prev * (L + drv[DRV_KUS] * v * v) - 2.0 * L * e / (d * d) + dist[k]
        for i in range(7):
            out[k, i] = x[i]
        out[k, 7] = dcmd
        for _ in range(substeps):
            _rhs(x, dcmd, v, rho, P, drv[DRV_STEER_TAU], k1)
            for i in range(7):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            _rhs(tmp, dcmd, v, rho, P, drv[DRV_STEER_TAU], k2)
            for i in range(7):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            _rhs(tmp, dcmd, v, rho, P, drv[DRV_STEER_TAU], k3)
            for i in range(7):
                tmp[i] = x[i] + h * k3[i]
            _rhs(tmp, dcmd, v, rho, P, drv[DRV_STEER_TAU], k4)
            for i in range(7):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return out


@njit(cache=True)
def _open_loop(t, vx, delta, rho, P, substeps, exact):
    """RK4 of S1 (8) + S2 (9) with a prescribed steering (actuator bypassed)."""
    N = t.shape[0]
    out = np.empty((N, 6))
    x = np.zeros(7)
    x[X_DELTA] = delta[0]
    k1 = np.empty(7)
    k2 = np.empty(7)
    k3 = np.empty(7)
    k4 = np.empty(7)
    tmp = np.empty(7)
    dt = t[1] - t[0]
    h = dt / substeps
    for k in range(N):
        x[X_DELTA] = delta[k]
        for i in range(6):
            out[k, i] = x[i]
        for _ in range(substeps):
            _rhs(x, delta[k], vx[k], rho[k], P, 1.0, k1, exact)
            k1[X_DELTA] = 0.0
            for i in range(7):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            _rhs(tmp, delta[k], vx[k], rho[k], P, 1.0, k2, exact)
            k2[X_DELTA] = 0.0
            for i in range(7):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            _rhs(tmp, delta[k], vx[k], rho[k], P, 1.0, k3, exact)
            k3[X_DELTA] = 0.0
            for i in range(7):
                tmp[i] = x[i] + h * k3[i]
            _rhs(tmp, delta[k], vx[k], rho[k], P, 1.0, k4, exact)
            for i in range(6):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return out


def understeer_gradient(p: LateralParams) -> float:
    """Linear understeer gradient ``K_us = m/L (a_r/C_f - a_f/C_r)`` [rad s^2/m]."""
    L = p.a_f + p.a_r
    return p.m / L * (p.a_r / p.tire_f.cornering_stiffness - p.a_f / p.tire_r.cornering_stiffness)


def _filtered_noise(rng, n, dt, std, tc):
    """First-order (AR(1)) Gauss-Markov noise with stationary std ``std`` and time constant tc."""
    a = np.exp(-dt / tc)
    w = rng.standard_normal(n) * std * np.sqrt(1 - a * a)
    return _ar1(w, a, rng.standard_normal() * std)


@njit(cache=True)
def _ar1(w, a, x0):
    out = np.empty_like(w)
    x = x0
    for k in range(w.shape[0]):
        out[k] = x
        x = a * x + w[k]
    return out


def _hold(x, t, rate_hz):
    """Sample-and-hold ``x`` at ``rate_hz`` frames (frame k holds from ``k / rate``)."""
    idx = np.floor(t * rate_hz + 1e-9) / rate_hz
    j = np.searchsorted(t, idx - 1e-12)
    return x[np.clip(j, 0, len(x) - 1)]


def _make_log(t, truth, rho, vx_true, delta_true, s, p, rng, noise_scale, vision_rate_hz,
              source, extra=None, exact_slip=True) -> DriveLog:
    if noise_scale < 0 or not np.isfinite(noise_scale):
        raise ValueError(f"noise_scale must be finite and >= 0, got {noise_scale}")
    if vision_rate_hz is not None and not (0 < vision_rate_hz <= FS_HZ):
        raise ValueError(f"vision_rate_hz must be in (0, {FS_HZ:g}] Hz or None, "
                         f"got {vision_rate_hz}")
    vy, r, Ff, Fr, psiL, yL = (truth[:, i].copy() for i in range(6))
    n = len(t)
    sd = {k: v * noise_scale for k, v in NOISE_STD.items()}
    noise = {k: rng.standard_normal(n) * sd[k] for k in NOISE_STD}   # fixed draw order
    ay_true = (Ff + Fr) / p.m
    yL_m, psiL_m = yL + noise["yL"], psiL + noise["psiL"]
    if vision_rate_hz is not None:
        yL_m, psiL_m = _hold(yL_m, t, vision_rate_hz), _hold(psiL_m, t, vision_rate_hz)
    af, ar = slip_angles(vy, r, delta_true, vx_true, p, exact_slip)
    ex = {"s_m": s, "vx_true_mps": vx_true, "delta_true_rad": delta_true,
          "yaw_rate_true_radps": r, "ay_true_mps2": ay_true, "yL_true_m": yL,
          "psiL_true_rad": psiL, "alpha_f_true_rad": af, "alpha_r_true_rad": ar,
          "FfS_true_N": p.tire_f.force(af), "FrS_true_N": p.tire_r.force(ar)}
    if extra:
        ex.update(extra)
    return DriveLog(t=t, vx=np.maximum(vx_true + noise["vx"], 0.05),
                    delta=delta_true + noise["delta"], yaw_rate=r + noise["yaw_rate"],
                    ay=ay_true + noise["ay"], vy=vy, yL=yL_m, psiL=psiL_m, Ff=Ff, Fr=Fr,
                    rho=rho, extra=ex, source=source)


def emulated_satory(seed: int = 0, quick: bool = False, noise_scale: float = 1.0,
                    vision_rate_hz: float | None = None, params: LateralParams | None = None,
                    substeps: int = 2, quick_duration: float = 40.0,
                    v_max: float = VX_MAX) -> DriveLog:
    """Emulated Satory track run (Yacine 2015 Sec. IV stand-in), 1 kHz, with ground truth.

    Parameters
    ----------
    seed : seeds the driver's steering disturbance and every sensor noise.
    quick : ``True`` -> the first ``quick_duration`` s of the lap (start at 0.2 m/s,
        acceleration to 17 m/s, the left R 80 m curve, the start of the S-bend); ``False`` ->
        the whole
        3.5 km lap (about 230 s, 0.2 -> 17 -> 0.2 m/s, 230,000 samples).
    noise_scale : multiplies every sensor noise std (:data:`NOISE_STD`); 0 = noise-free.
    vision_rate_hz : ``None`` -> vision at 1 kHz; else ``y_L, psi_L`` frames at this rate,
        held between frames (e.g. 25 Hz for a camera).
    params : vehicle (default: ``yacine_2015.constants.params``, the paper's car with the chosen
        Pacejka tyres).
    substeps : RK4 steps per 1 ms sample.
    v_max : top speed of the speed profile [m/s] (default the paper's ``v_x^max`` = 17; a
        lower value keeps the *measured* ``v_x`` (true + noise) inside the TS sector).

    Returns
    -------
    DriveLog with measured ``t, vx, delta, yaw_rate, ay, yL, psiL`` and truth
    ``vy, Ff, Fr, rho`` (shape (N,)); ``extra`` holds ``s_m`` and the ``*_true`` channels.
    """
    p = params or _default_params()
    rng = np.random.default_rng(seed)
    track = satory_track()
    sg, vg = speed_profile(track, v_max=v_max)
    t, s, vx = time_grid(sg, vg, t_end=quick_duration if quick else None)
    dist = _filtered_noise(rng, len(t), 1.0 / FS_HZ, STEER_DIST_STD, STEER_DIST_TC)
    drv = np.empty(5)
    drv[DRV_PREVIEW_TIME], drv[DRV_PREVIEW_MIN], drv[DRV_KUS] = (PREVIEW_TIME, PREVIEW_MIN,
                                                               understeer_gradient(p))
    drv[DRV_STEER_TAU], drv[DRV_FF_PREVIEW] = STEER_TAU, FF_PREVIEW_TIME
    X0 = np.zeros(7)
    out = _closed_loop(t, s, vx, track.s_knots, track.rho_knots, track.length, p.as_array(),
                       dist, drv, int(substeps), X0)
    rho = track.rho(s)
    log = _make_log(t, out[:, :6], rho, vx, out[:, 6], s, p, rng, noise_scale, vision_rate_hz,
                    source=f"emulated_satory(seed={seed}, quick={quick}, "
                           f"noise_scale={noise_scale:g}, vision_rate_hz={vision_rate_hz}"
                           + (f", v_max={v_max:g})" if v_max != VX_MAX else ")"),
                    extra={"delta_cmd_rad": out[:, 7]})
    return log


def sine_with_dwell(seed: int = 0, vx: float = 17.0, amplitude: float | None = None,
                    frequency_hz: float = 0.7, dwell: float = 0.5, t_before: float = 1.0,
                    t_after: float = 4.0, noise_scale: float = 1.0,
                    vision_rate_hz: float | None = None, params: LateralParams | None = None,
                    target_front_slip_deg: float = 7.0, substeps: int = 2) -> DriveLog:
    """Sine-with-dwell steering at constant speed on a straight road (``rho = 0``), 1 kHz.

    Steering (road-wheel angle, FMVSS 126 shape): ``A sin(2 pi f t)`` for the first 3/4
    period, held at ``-A`` for ``dwell`` s, then the last quarter period back to zero.
    ``amplitude=None`` picks ``A`` so that the steady-state front slip of the linear model
    at ``A`` equals ``target_front_slip_deg`` -- deep in the nonlinear tyre region (the
    transient slip then exceeds it). Same truth model and sensors as :func:`emulated_satory`.
    """
    p = params or _default_params()
    if not (0 < vx):
        raise ValueError(f"vx must be > 0 m/s, got {vx}")
    rng = np.random.default_rng(seed)
    T = t_before + 0.75 / frequency_hz + dwell + 0.25 / frequency_hz + t_after
    t = np.arange(0.0, T, 1.0 / FS_HZ)
    if amplitude is None:
        # linear steady state: alpha_f = delta * (1 - (L + K_us v^2)^-1 * ...); use
        # alpha_f = m a_r / (L C_f) * a_y and a_y = v^2 delta / (L + K_us v^2)
        L = p.a_f + p.a_r
        Kus = understeer_gradient(p)
        ay_per_delta = vx**2 / (L + Kus * vx**2)
        af_per_delta = p.m * p.a_r / (L * p.tire_f.cornering_stiffness) * ay_per_delta
        amplitude = np.radians(target_front_slip_deg) / af_per_delta
    w = 2 * np.pi * frequency_hz
    tau = t - t_before
    t1 = 0.75 / frequency_hz
    delta = np.where(tau < 0, 0.0, np.where(tau < t1, amplitude * np.sin(w * tau), 0.0))
    delta = np.where((tau >= t1) & (tau < t1 + dwell), -amplitude, delta)
    tau2 = tau - t1 - dwell
    delta = np.where((tau2 >= 0) & (tau2 < 0.25 / frequency_hz),
                     amplitude * np.sin(w * (tau2 + t1)), delta)
    vxa = np.full_like(t, float(vx))
    rho = np.zeros_like(t)
    out = _open_loop(t, vxa, delta, rho, p.as_array(), int(substeps), True)
    return _make_log(t, out, rho, vxa, delta, vxa * t, p, rng, noise_scale, vision_rate_hz,
                     source=f"sine_with_dwell(seed={seed}, vx={vx:g}, A={amplitude:.4g} rad)")


def replay(log: DriveLog, exact_slip: bool = False, params: LateralParams | None = None,
           seed: int = 0, noise_scale: float = 0.0, vision_rate_hz: float | None = None,
           substeps: int = 2) -> DriveLog:
    """Re-simulate the truth of ``log`` open loop from its true steering, speed and curvature.

    ``exact_slip=False`` uses the small-angle slip angles (4), so the truth is the model
    (13) that the 8-rule TS form (24) represents *exactly* inside its sector (Yacine 2015
    Sec. III-B); ``True`` uses the exact slip (3). S2 (9) is integrated alongside. Used for
    the theory check of Theorem 1 (bound (34)). Inputs are taken from ``log.extra``
    (``delta_true_rad``, ``vx_true_mps``) and ``log.rho``; sensors as in
    :func:`emulated_satory` (noise-free by default).
    """
    p = params or _default_params()
    log.require("rho_1pm", purpose="replay")
    for c in ("delta_true_rad", "vx_true_mps"):
        if c not in log.extra:
            raise ValueError(f"{log.source or 'log'}: replay needs the truth column {c!r} "
                             "(logs from emulated_satory / sine_with_dwell have it)")
    delta = np.ascontiguousarray(log.extra["delta_true_rad"])
    vx = np.ascontiguousarray(log.extra["vx_true_mps"])
    rho = np.ascontiguousarray(log.rho, dtype=float)
    out = _open_loop(log.t, vx, delta, rho, p.as_array(), int(substeps), bool(exact_slip))
    rng = np.random.default_rng(seed)
    s = log.extra.get("s_m", np.cumsum(vx) * log.dt)
    kind = "exact slip (3)" if exact_slip else "small-angle slip (4)"
    return _make_log(log.t, out, rho, vx, delta, s, p, rng, noise_scale, vision_rate_hz,
                     source=f"replay[{kind}] of {log.source}", exact_slip=bool(exact_slip))
