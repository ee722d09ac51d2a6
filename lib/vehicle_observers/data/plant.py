"""Independent truth plant: the CommonRoad multi-body model driven along the repository's
manoeuvres, written as :class:`~vehicle_observers.data.logs.DriveLog` in the repository's schema.

Plant (not written here)
------------------------
``vehiclemodels.vehicle_dynamics_mb.vehicle_dynamics_mb`` of the PyPI package
``commonroad-vehicle-models`` 3.0.2 (Althoff & Wuersching, "CommonRoad: Vehicle Models",
TU Munich 2020, Sec. 6): 29 states (sprung mass with roll / pitch / heave, front and rear
unsprung masses, four wheel spins, compliant joints), PAC2002-type magic-formula tyres with
combined slip and camber, load transfer through the suspension. Parameters are the library's
own vehicle files (``parameters_vehicle2`` = BMW 320i by default). Its inputs are the
road-wheel steering *rate* ``u_1`` [rad/s] and the longitudinal acceleration ``u_2``
[m/s^2], both clipped by the library's own actuator limits (steering rate 0.4 rad/s for the
BMW).

Driver (documented here, the only code of this module in the loop)
------------------------------------------------------------------
- steering servo ``u_1 = (delta_ref - delta) / tau_s`` with ``tau_s = 0.05 s`` (the library
  then clips the rate);
- speed controller ``u_2 = dv_ref/dt + k_v (v_ref - v_x)`` with ``k_v = 1 1/s``.

Integration: fixed-step classical RK4 of the library's right-hand side, ``h = 2 ms`` (the
fastest mode, wheel spin at 5 m/s, is about 700 1/s, so ``h |lambda| = 1.4 < 2.8``), logged
every 10 ms (100 Hz). The library switches to a kinematic model below 0.1 m/s; every
manoeuvre here starts at speed.

Log (schema of :mod:`vehicle_observers.data.logs`)
--------------------------------------------------
Truth: ``vy_mps`` = sprung-mass lateral velocity at the CG (state x11, the one the library's
own side-slip ``beta`` uses), ``Ff_N`` / ``Fr_N`` = equivalent bicycle axle lateral forces
defined by the lateral and yaw balance of the whole car,
``m a_y = F_f + F_r``, ``I_z r' = l_f F_f - l_r F_r`` (``a_y`` the mass-weighted lateral
acceleration of sprung and unsprung bodies, ``r'`` the library's yaw acceleration).
Measured (seeded, Gaussian white, std :data:`NOISE_STD`): ``vx_mps``, ``delta_roadwheel_rad``
(the plant's actual road-wheel angle), ``yaw_rate_radps``, ``ay_mps2``: an accelerometer
fixed to the sprung mass (``accelerometer="body"``, the default) reads the specific force
along the body's lateral axis,

    a_y,meas = a_y cos(phi) - g sin(phi),     a_y = v_y' + r v_x  (sprung mass, level frame),

with ``phi`` the library's roll angle, which is negative when the body rolls towards the
right (outward in a left turn, where ``a_y > 0``): the sensor reads *more* than the
horizontal acceleration in every turn, by about ``g |phi|`` (the BMW rolls about 9 deg per
g, so about 16 %). ``accelerometer="level"`` gives the level-frame ``a_y`` (a roll-compensated
sensor). The noise-free channels are kept in ``extra`` (``vx_true_mps``, ``delta_true_rad``,
``yaw_rate_true_radps``, ``ay_true_mps2`` (level frame), ``ay_sensor_true_mps2`` (what the
accelerometer reads), ``roll_true_rad`` (the library's roll angle ``phi``, positive left side
down: named as a truth channel, so no estimator reads it as an INS roll column)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import Pacejka

#: sensor noise standard deviations of the plant logs (SI units; same as the emulated logs)
NOISE_STD = {"yaw_rate": 0.002, "delta": 2e-4, "vx": 0.02, "ay": 0.05}
H_STEP = 0.002      # s, RK4 step
LOG_HZ = 100.0      # Hz, log rate
TAU_STEER = 0.05    # s, steering servo time constant
K_SPEED = 1.0       # 1/s, speed controller gain
G = 9.81            # the library's gravity constant


def _lib():
    try:
        from vehiclemodels.init_mb import init_mb
        from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb
        from vehiclemodels.vehicle_parameters import setup_vehicle_parameters
    except ImportError as exc:  # pragma: no cover - environment.txt pins it
        raise ImportError("the independent plant needs 'commonroad-vehicle-models' "
                          "(pinned in environment.txt)") from exc
    return init_mb, vehicle_dynamics_mb, setup_vehicle_parameters


def plant_parameters(vehicle_id: int = 2):
    """The library's parameter set (OmegaConf) of CommonRoad vehicle ``vehicle_id``
    (1 Ford Escort, 2 BMW 320i, 3 VW Vanagon)."""
    return _lib()[2](vehicle_id=vehicle_id)


def static_axle_loads(p) -> tuple[float, float]:
    """Static front / rear axle loads [N] of the library's car (sprung share by the CG
    position plus the unsprung mass of that axle)."""
    L = p.a + p.b
    return (p.m_s * G * p.b / L + p.m_uf * G, p.m_s * G * p.a / L + p.m_ur * G)


def nominal_params(vehicle_id: int = 2) -> LateralParams:
    """Bicycle-model constants read off the library's data sheet (no fitting): ``m``,
    ``I_z``, ``l_f = a``, ``l_r = b`` and per-axle Pacejka tyres at the static load,
    ``B C D = |p_ky1| F_z`` (PAC2002 ``K_y = p_ky1 F_z`` as simplified in the library),
    ``C = p_cy1``, ``D = p_dy1 F_z``, ``E = p_ey1``. Camber, load transfer, compliance and
    combined slip are what the bicycle model leaves out (the mismatch)."""
    p = plant_parameters(vehicle_id)
    t = p.tire
    tyres = []
    for Fz in static_axle_loads(p):
        D = t.p_dy1 * Fz
        tyres.append(Pacejka(B=abs(t.p_ky1) * Fz / (t.p_cy1 * D), C=t.p_cy1, D=D, E=t.p_ey1))
    return LateralParams(m=float(p.m), I_z=float(p.I_z), a_f=float(p.a), a_r=float(p.b),
                         tire_f=tyres[0], tire_r=tyres[1], name=f"CommonRoad vehicle "
                         f"{vehicle_id} (multi-body plant)")


@dataclass(frozen=True)
class Manoeuvre:
    """Reference road-wheel steering [rad] and speed [m/s] on the grid ``t`` [s] (N,)."""

    name: str
    t: np.ndarray
    delta_ref: np.ndarray
    v_ref: np.ndarray


def sine_with_dwell_manoeuvre(vx: float = 20.0, amplitude: float = 0.05,
                              frequency_hz: float = 0.5, dwell: float = 0.5,
                              t_before: float = 1.0, t_after: float = 4.0) -> Manoeuvre:
    """FMVSS-126-shaped steering (as :func:`~vehicle_observers.data.scenarios.sine_with_dwell`)
    at constant speed; road-wheel amplitude ``amplitude`` [rad]."""
    T = t_before + 0.75 / frequency_hz + dwell + 0.25 / frequency_hz + t_after
    t = np.arange(0.0, T, 1.0 / LOG_HZ)
    w = 2 * np.pi * frequency_hz
    tau = t - t_before
    t1 = 0.75 / frequency_hz
    d = np.where((tau >= 0) & (tau < t1), amplitude * np.sin(w * tau), 0.0)
    d = np.where((tau >= t1) & (tau < t1 + dwell), -amplitude, d)
    tau2 = tau - t1 - dwell
    d = np.where((tau2 >= 0) & (tau2 < 0.25 / frequency_hz), amplitude * np.sin(w * (tau2 + t1)),
                 d)
    return Manoeuvre("sine_with_dwell", t, d, np.full_like(t, float(vx)))


def slalom_manoeuvre(vx: float = 18.0, amplitude: float = 0.035, frequency_hz: float = 0.4,
                     duration: float = 20.0, ramp: float = 2.0) -> Manoeuvre:
    """Slalom: sinusoidal road-wheel steering ``A sin(2 pi f t)`` after a ``ramp`` s fade-in,
    at constant speed."""
    t = np.arange(0.0, duration, 1.0 / LOG_HZ)
    env = np.clip(t / ramp, 0.0, 1.0)
    return Manoeuvre("slalom", t, amplitude * env * np.sin(2 * np.pi * frequency_hz * t),
                     np.full_like(t, float(vx)))


def satory_manoeuvre(duration: float = 60.0, t_start: float = 15.0) -> Manoeuvre:
    """The Satory-like lap's true road-wheel steering and speed
    (:func:`~vehicle_observers.data.scenarios.emulated_satory`, noise-free channels), from
    ``t_start`` s (the lap starts at 0.2 m/s; the plant starts at speed) for ``duration`` s,
    resampled at 100 Hz. The steering is replayed open loop (no path following): the plant
    car is not the lap's car, so it drives its own path with the same driver inputs."""
    from vehicle_observers.data.scenarios import emulated_satory
    need = t_start + duration
    log = emulated_satory(seed=0, quick=True, noise_scale=0.0, quick_duration=need + 0.01)
    t = np.arange(0.0, duration, 1.0 / LOG_HZ)
    d = np.interp(t + t_start, log.t, log.extra["delta_true_rad"])
    v = np.interp(t + t_start, log.t, log.extra["vx_true_mps"])
    return Manoeuvre("satory", t, d, v)


def ramp_steer_manoeuvre(vx: float = 20.0, delta_max: float = 0.012,
                        duration: float = 20.0) -> Manoeuvre:
    """Quasi-steady ramp steer at constant speed (``delta`` from 0 to ``delta_max`` rad over
    ``duration`` s): nearly steady-state cornering, where yaw rate and lateral acceleration
    only determine the understeer gradient, not each axle's stiffness."""
    t = np.arange(0.0, duration, 1.0 / LOG_HZ)
    return Manoeuvre("ramp_steer", t, delta_max * t / duration, np.full_like(t, float(vx)))


MANOEUVRES = {"sine_with_dwell": sine_with_dwell_manoeuvre, "slalom": slalom_manoeuvre,
              "satory": satory_manoeuvre, "ramp_steer": ramp_steer_manoeuvre}


def _rk4(f, x, u, p, h):
    k1 = np.asarray(f(list(x), u, p))
    k2 = np.asarray(f(list(x + 0.5 * h * k1), u, p))
    k3 = np.asarray(f(list(x + 0.5 * h * k2), u, p))
    k4 = np.asarray(f(list(x + h * k3), u, p))
    return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), k1


#: accelerometer models of :func:`simulate` (module docstring)
ACCELEROMETERS = ("body", "level")


def simulate(man: Manoeuvre, vehicle_id: int = 2, seed: int = 0, noise_scale: float = 1.0,
             h: float = H_STEP, accelerometer: str = "body") -> DriveLog:
    """Drive the multi-body plant along ``man`` and return the log (100 Hz, see module
    docstring for every channel). ``seed`` draws every sensor noise; ``noise_scale``
    multiplies :data:`NOISE_STD` (0 = noise-free measured channels); ``accelerometer``:
    ``"body"`` (fixed to the rolling sprung mass) or ``"level"`` (roll-compensated)."""
    if accelerometer not in ACCELEROMETERS:
        raise ValueError(f"accelerometer must be one of {ACCELEROMETERS}, got {accelerometer!r}")
    if not (np.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be finite and >= 0, got {noise_scale}")
    if man.v_ref[0] < 1.0:
        raise ValueError(f"manoeuvre {man.name!r} starts at v_ref = {man.v_ref[0]:g} m/s; "
                         "the plant log needs v_x > 1 m/s from the start")
    init_mb, f, _ = _lib()
    p = plant_parameters(vehicle_id)
    dt = float(man.t[1] - man.t[0])
    sub = int(round(dt / h))
    if sub < 1 or abs(sub * h - dt) > 1e-9:
        raise ValueError(f"the log period {dt} s must be a multiple of the RK4 step {h} s")
    x = np.asarray(init_mb([0.0, 0.0, float(man.delta_ref[0]), float(man.v_ref[0]), 0.0, 0.0,
                            0.0], p), dtype=float)
    dv = np.gradient(man.v_ref, man.t)
    N = len(man.t)
    rec = np.empty((N, 8))
    # A diverging state (e.g. a wheel speed reaching 0 in the package's slip ratio) is caught
    # below as one FloatingPointError naming the time; the package's own scalar warnings on
    # the way there would only repeat it on stderr.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(N):
            u = [(man.delta_ref[k] - x[2]) / TAU_STEER, dv[k] + K_SPEED * (man.v_ref[k] - x[3])]
            fx = np.asarray(f(list(x), u, p))
            ay_s = fx[10] + x[5] * x[3]
            ay_cg = (p.m_s * ay_s + p.m_uf * (fx[15] + x[5] * x[3])
                     + p.m_ur * (fx[20] + x[5] * x[3])) / p.m
            rec[k] = (x[3], x[2], x[5], x[10], ay_s, ay_cg, fx[5], x[6])
            for _ in range(sub):
                x, _k1 = _rk4(f, x, u, p, h)
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(rec[k]))):
                raise FloatingPointError(f"plant diverged at t = {man.t[k]:.2f} s ({man.name})")
    vx, dl, r, vy, ay_s, ay_cg, rdot, roll = rec.T
    L = p.a + p.b
    # m a_y = Ff + Fr ; Iz r' = a Ff - b Fr
    Ff = (p.m * ay_cg * p.b + p.I_z * rdot) / L
    Fr = (p.m * ay_cg * p.a - p.I_z * rdot) / L
    rng = np.random.default_rng(seed)
    sd = {c: s * noise_scale for c, s in NOISE_STD.items()}
    nz = {c: rng.standard_normal(N) * sd[c] for c in NOISE_STD}     # fixed draw order
    ay_sensor = ay_s * np.cos(roll) - G * np.sin(roll) if accelerometer == "body" else ay_s
    extra = {"vx_true_mps": vx, "delta_true_rad": dl, "yaw_rate_true_radps": r,
             "ay_true_mps2": ay_s, "ay_sensor_true_mps2": ay_sensor, "roll_true_rad": roll,
             "delta_ref_rad": man.delta_ref.copy()}
    return DriveLog(t=man.t.copy(), vx=vx + nz["vx"], delta=dl + nz["delta"],
                    yaw_rate=r + nz["yaw_rate"], ay=ay_sensor + nz["ay"], vy=vy, Ff=Ff, Fr=Fr,
                    extra=extra,
                    source=f"commonroad MB plant (vehicle {vehicle_id}): {man.name}, "
                           f"seed={seed}, noise_scale={noise_scale:g}, "
                           f"{accelerometer} accelerometer")


def plant_log(name: str, seed: int = 0, quick: bool = False, vehicle_id: int = 2,
              noise_scale: float = 1.0, accelerometer: str = "body") -> DriveLog:
    """One of :data:`MANOEUVRES` on the plant; ``quick`` shortens the Satory replay to 20 s
    and the slalom to 10 s; ``accelerometer`` as in :func:`simulate`."""
    if name not in MANOEUVRES:
        raise ValueError(f"unknown manoeuvre {name!r}; expected one of {', '.join(MANOEUVRES)}")
    kw = {}
    if quick and name == "satory":
        kw = {"duration": 20.0}
    elif quick and name == "slalom":
        kw = {"duration": 10.0}
    return simulate(MANOEUVRES[name](**kw), vehicle_id=vehicle_id, seed=seed,
                    noise_scale=noise_scale, accelerometer=accelerometer)


def max_front_slip_deg(log: DriveLog, p: LateralParams) -> float:
    """Largest small-angle front slip ``|delta - (v_y + l_f r)/v_x|`` [deg] of the truth."""
    ex = log.extra
    a = ex["delta_true_rad"] - (log.vy + p.a_f * ex["yaw_rate_true_radps"]) / ex["vx_true_mps"]
    return math.degrees(float(np.abs(a).max()))
