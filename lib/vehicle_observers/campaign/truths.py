"""Truth plants, noisy logs and the observer's vehicle files of a campaign.

A *truth* is one noise-free drive of a plant (registered in
:mod:`vehicle_observers.campaign.plants`; a plug-in adds its own with
:func:`~vehicle_observers.campaign.plants.register_plant`) along a manoeuvre
(:data:`vehicle_observers.data.plant.MANOEUVRES`: reference road-wheel angle and speed on a
100 Hz grid):

* ``multibody``: :func:`vehicle_observers.data.plant.simulate` with ``noise_scale = 0`` (the
  CommonRoad multi-body model, its steering servo and speed controller; body-fixed
  accelerometer), 100 Hz;
* ``yaw-drift``: the reference steering and speed (linear interpolation onto 1 kHz) replayed
  through the repository's Yacine 2015 model S1 + S2 with exact slip and relaxation
  (:func:`vehicle_observers.data.scenarios.replay`), ``a_y = (F_f + F_r)/m``;
* ``lpv``: Ifqir 2017's LPV bicycle (3) at the car's nominal stiffness, explicit Euler at the
  sample period (:func:`vehicle_observers.models.uncertain_bicycle.simulate_lpv`, the scheme the
  interval observers' guarantee is exact for), inputs the reference signals sampled at the
  rate; linear axle forces, ``a_y = (F_f + F_r)/m``.

A *log* is a truth decimated to the sample rate plus sensor noise and constant biases
(:func:`make_log`); a *variant* is the observer's vehicle file: the car's nominal constants
with relative errors and the campaign's ``[uncertainty]`` box (:func:`observer_vehicle`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from vehicle_observers.campaign.plants import COMMONROAD_CARS, get_plant, register_plant
from vehicle_observers.campaign.spec import COMMONROAD_SPEED_RANGE
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.tires import LinearTire, Pacejka
from vehicle_observers.models.vehicle import KalmanTuning, Vehicle

#: slip angles below this are left out of the truth's effective stiffness [deg]
MIN_SLIP_DEG = 0.5
#: floor of a standard deviation in the Kalman table, relative to the default (noise 0)
STD_FLOOR_REL = 1e-3
#: measured speed never below this [m/s] (as the emulated logs)
VX_FLOOR = 0.05
#: standard deviation of the longitudinal accelerometer's noise at noise scale 1 [m/s^2]
#: (that of the lateral one, ``DEFAULT_STD["ay"]``)
AX_STD = 0.05


@dataclass
class Truth:
    """A noise-free drive: ``t`` (N,) [s] at ``rate`` [Hz]; channels (N,) in SI units:
    ``vx``, ``delta`` (road-wheel), ``r``, ``ay`` (what a noise-free accelerometer reads),
    ``vy``, ``Ff``, ``Fr``; ``extra`` optional ``yL``, ``psiL``, ``rho``. ``stiffness`` holds
    the effective axle stiffness of the truth relative to the car's nominal slope,
    ``F / alpha / C_0`` over the samples with ``|alpha| >= MIN_SLIP_DEG`` (min, max per axle;
    exactly 1 for ``lpv``)."""

    key: tuple
    t: np.ndarray
    rate: float
    vx: np.ndarray
    delta: np.ndarray
    r: np.ndarray
    ay: np.ndarray
    vy: np.ndarray
    Ff: np.ndarray
    Fr: np.ndarray
    extra: dict = field(default_factory=dict)
    stiffness: dict = field(default_factory=dict)
    source: str = ""

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.t, self.vx, self.delta, self.r, self.ay, self.vy,
                                      self.Ff, self.Fr, *self.extra.values()))


# ------------------------------------------------------------------ cars -----------------
@lru_cache(maxsize=None)
def car_vehicle(car: str) -> Vehicle:
    """The car's nominal vehicle file: a shipped one (``yacine2015``, ``revs250lm``) or, for a
    CommonRoad car, the data-sheet constants of :func:`vehicle_observers.data.plant.nominal_params`
    with the box ``stiffness_rel 0.1``, ``[5, 40] m/s``, ``slip_max_deg 8``."""
    if car in COMMONROAD_CARS:
        from vehicle_observers.data import plant

        p = plant.nominal_params(COMMONROAD_CARS[car])
        lo, hi = COMMONROAD_SPEED_RANGE
        return Vehicle(name=f"{car} (CommonRoad data sheet)", params=p,
                       uncertainty={"stiffness_rel": 0.1, "vx_min": lo, "vx_max": hi,
                                    "slip_max_deg": 8.0})
    from vehicle_observers.models.vehicle import load_vehicle

    return load_vehicle(car)


def _scale_tyre(tyre, stiffness: float, friction: float):
    """Tyre with its slope at zero slip times ``stiffness`` and its peak times ``friction``
    (Pacejka: ``D -> friction D``, ``B -> B stiffness / friction``; a linear tyre has no peak)."""
    if isinstance(tyre, LinearTire):
        return LinearTire(tyre.C_alpha * stiffness)
    return Pacejka(B=tyre.B * stiffness / friction, C=tyre.C, D=tyre.D * friction, E=tyre.E)


def observer_vehicle(car: str, errors: dict, rel: float, speed, tuning=None) -> Vehicle:
    """The observer's vehicle file: the car's constants times ``1 + error`` (keys of
    :data:`~vehicle_observers.campaign.spec.ERROR_KEYS`; ``stiffness`` scales both axles,
    ``stiffness_front``/``_rear`` one more), ``[uncertainty]`` ``stiffness_rel = rel`` and
    ``speed = (vx_min, vx_max)`` (``None``: the car's), ``[kalman]`` ``tuning`` if given."""
    v = car_vehicle(car)
    p = v.params
    e = {k: float(x) for k, x in errors.items()}
    s = 1.0 + e.get("stiffness", 0.0)
    mu = 1.0 + e.get("friction", 0.0)
    params = dataclasses.replace(
        p, m=p.m * (1.0 + e.get("mass", 0.0)), I_z=p.I_z * (1.0 + e.get("inertia", 0.0)),
        a_f=p.a_f * (1.0 + e.get("a_f", 0.0)), a_r=p.a_r * (1.0 + e.get("a_r", 0.0)),
        tire_f=_scale_tyre(p.tire_f, s * (1.0 + e.get("stiffness_front", 0.0)), mu),
        tire_r=_scale_tyre(p.tire_r, s * (1.0 + e.get("stiffness_rear", 0.0)), mu))
    unc = dict(v.uncertainty)
    unc.setdefault("slip_max_deg", 8.0)
    unc["stiffness_rel"] = float(rel)
    if speed is not None:
        unc["vx_min"], unc["vx_max"] = float(speed[0]), float(speed[1])
    return Vehicle(name=v.name, params=params, uncertainty=unc,
                   kalman=tuning if tuning is not None else v.kalman, path=v.path)


def sensor_tuning(std: dict, scale: float) -> KalmanTuning:
    """``[kalman]`` table from the sensor noise: ``R_r``, ``R_ay`` the variances of the
    yaw-rate and a_y noise (floored at :data:`STD_FLOOR_REL` of the default std), the process
    intensities the defaults of :class:`~vehicle_observers.models.vehicle.KalmanTuning`."""
    from vehicle_observers.campaign.spec import DEFAULT_STD

    sr = max(scale * std["yaw_rate"], STD_FLOOR_REL * DEFAULT_STD["yaw_rate"])
    sa = max(scale * std["ay"], STD_FLOOR_REL * DEFAULT_STD["ay"])
    return dataclasses.replace(KalmanTuning(), R_r=sr ** 2, R_ay=sa ** 2,
                               source=f"campaign sensors (noise scale {scale:g})")


# ------------------------------------------------------------------ truths ----------------
def manoeuvre(man):
    """:class:`vehicle_observers.data.plant.Manoeuvre` of ``(name, ((key, value), ...))``."""
    from vehicle_observers.data import plant

    name, kw = man
    return plant.MANOEUVRES[name](**dict(kw))


def effective_stiffness(vy, r, delta, vx, Ff, Fr, params, c_f0, c_r0) -> dict:
    """Min / max of ``F / alpha / C_0`` per axle over the samples with ``|alpha| >=
    MIN_SLIP_DEG`` (small-angle slip of the bicycle model); NaN when no sample qualifies."""
    af = delta - (vy + params.a_f * r) / vx
    ar = -(vy - params.a_r * r) / vx
    out = {}
    for ax, F, a, c0 in (("f", Ff, af, c_f0), ("r", Fr, ar, c_r0)):
        k = np.abs(a) >= np.radians(MIN_SLIP_DEG)
        q = F[k] / a[k] / c0 if k.any() else np.array([np.nan])
        out[f"c{ax}_min"], out[f"c{ax}_max"] = float(np.min(q)), float(np.max(q))
    return out


def _multibody(car, m, rate) -> dict:
    from vehicle_observers.data import plant as mb

    log = mb.simulate(m, vehicle_id=COMMONROAD_CARS[car], seed=0, noise_scale=0.0)
    return {"t": log.t, "vx": log.vx, "delta": log.delta, "r": log.yaw_rate, "ay": log.ay,
            "vy": log.vy, "Ff": log.Ff, "Fr": log.Fr}


def _yaw_drift(car, m, rate) -> dict:
    from vehicle_observers.data import scenarios

    p = car_vehicle(car).params
    fs = 1000.0
    t = np.arange(int(round((m.t[-1] - m.t[0]) * fs)) + 1) / fs + m.t[0]
    d = np.interp(t, m.t, m.delta_ref)
    v = np.interp(t, m.t, m.v_ref)
    ref = DriveLog(t=t, vx=v, delta=d, yaw_rate=np.zeros_like(t), rho=np.zeros_like(t),
                   extra={"delta_true_rad": d, "vx_true_mps": v}, source=m.name)
    log = scenarios.replay(ref, exact_slip=True, params=p, noise_scale=0.0)
    return {"t": t, "vx": v, "delta": d, "r": log.extra["yaw_rate_true_radps"],
            "ay": log.extra["ay_true_mps2"], "vy": log.vy, "Ff": log.Ff, "Fr": log.Fr,
            "extra": {"yL": log.extra["yL_true_m"], "psiL": log.extra["psiL_true_rad"],
                      "rho": log.rho}}


def _lpv(car, m, rate) -> dict:
    from vehicle_observers.models.uncertain_bicycle import UncertainBicycle, simulate_lpv

    veh = car_vehicle(car)
    p = veh.params
    dt = 1.0 / float(rate)
    t = m.t[0] + dt * np.arange(int(np.floor((m.t[-1] - m.t[0]) / dt + 1e-9)) + 1)
    d = np.interp(t, m.t, m.delta_ref)
    v = np.interp(t, m.t, m.v_ref)
    cf, cr = veh.C_f, veh.C_r
    ub = UncertainBicycle(m=p.m, I_z=p.I_z, l_f=p.a_f, l_r=p.a_r, c_f0=cf, c_r0=cr,
                          rel_unc=0.0, name=veh.name)
    X = simulate_lpv(ub, [0.0, 0.0], d, v, np.array([cr, cf]), dt, substeps=1,
                     method="euler")
    vy, r = X[:, 0], X[:, 1]
    Ff = cf * (d - (vy + p.a_f * r) / v)
    Fr = cr * (-(vy - p.a_r * r) / v)
    return {"t": t, "vx": v, "delta": d, "r": r, "ay": (Ff + Fr) / p.m, "vy": vy,
            "Ff": Ff, "Fr": Fr}


register_plant("multibody", _multibody, native_rate=100.0, cars=tuple(COMMONROAD_CARS),
               description="CommonRoad multi-body plant (data.plant.simulate), 100 Hz")
register_plant("yaw-drift", _yaw_drift, native_rate=1000.0,
               extra_columns=("yL_m", "psiL_rad", "rho_1pm"),
               description="Yacine 2015 S1 + S2 with relaxation and vision (scenarios.replay)")
register_plant("lpv", _lpv, native_rate=None,
               description="Ifqir 2017 LPV bicycle, Euler at the sample rate")


def simulate_truth(plant: str, car: str, man, rate: float | None = None) -> Truth:
    """The noise-free truth of ``plant`` (a registered one:
    :func:`~vehicle_observers.campaign.plants.get_plant`) with ``car`` along ``man``
    (module docstring); ``rate`` [Hz] is used by plants simulated at the sample rate
    (``native_rate`` None, e.g. ``lpv``). Adds ``extra["ax"]``, the longitudinal reading of
    a body-fixed accelerometer, ``dv_x/dt - v_y r`` (central differences), when the plant
    gives none."""
    from vehicle_observers.campaign.spec import truth_key

    key = truth_key(plant, car, man, rate)
    ps = get_plant(plant)
    veh = car_vehicle(car)
    p = veh.params
    m = manoeuvre(man)
    label = f"{plant}:{car} {m.name}"
    ch = ps.simulate(car, m, rate)
    fs = ps.native_rate if ps.native_rate is not None else float(rate)
    arr = {k: np.asarray(ch[k], float) for k in ("t", "vx", "delta", "r", "ay", "vy", "Ff", "Fr")}
    extra = {k: np.asarray(v, float) for k, v in (ch.get("extra") or {}).items()}
    tr = Truth(key, arr["t"], fs, arr["vx"], arr["delta"], arr["r"], arr["ay"], arr["vy"],
               arr["Ff"], arr["Fr"], extra=extra, source=label)
    if not all(np.all(np.isfinite(a)) for a in (tr.vx, tr.delta, tr.r, tr.vy)):
        raise FloatingPointError(f"{label}: the truth is not finite")
    if "ax" not in tr.extra and len(tr.t) > 1:
        tr.extra["ax"] = np.gradient(tr.vx, tr.t) - tr.vy * tr.r
    tr.stiffness = effective_stiffness(tr.vy, tr.r, tr.delta, tr.vx, tr.Ff, tr.Fr, p,
                                       veh.C_f, veh.C_r)
    return tr


# ------------------------------------------------------------------ noisy logs ------------
def make_log(truth: Truth, rate: float, std: dict, scale: float, bias: dict,
             distribution: str, rng: np.random.Generator) -> DriveLog:
    """The truth decimated to ``rate`` [Hz] plus noise and constant ``bias`` per channel.

    Noise: ``scale * std[channel]`` standard deviation, ``"gaussian"`` or ``"uniform"``
    (``+- sqrt(3)`` std, bounded); drawn from ``rng`` in the fixed order of ``std``'s keys
    (``yaw_rate, delta, vx, ay, yL, psiL``), one value per sample of the decimated log, for
    every channel whether the log has it or not (so a log's draws do not depend on the
    plant). Truth columns: ``vy``, ``Ff``, ``Fr``; ``extra`` holds the noise-free
    ``yaw_rate_true_radps``, ``vx_true_mps``, ``delta_true_rad`` and ``ax_mps2`` (the
    truth's longitudinal acceleration plus noise of :data:`AX_STD` x ``scale``, drawn after
    every other channel, so that the other channels' draws are those of a log without it)."""
    q = int(round(truth.rate / rate))
    sl = slice(None, None, q)
    t = truth.t[sl]
    n = len(t)
    noise = {}
    for c, s in std.items():
        if distribution == "uniform":
            w = rng.uniform(-np.sqrt(3.0), np.sqrt(3.0), n)
        else:
            w = rng.standard_normal(n)
        noise[c] = scale * s * w + bias.get(c, 0.0)
    ex = truth.extra
    vx = truth.vx[sl]
    has_vision = "yL" in ex
    extra = {"yaw_rate_true_radps": truth.r[sl].copy(), "vx_true_mps": vx.copy(),
             "delta_true_rad": truth.delta[sl].copy()}
    if "ax" in ex:
        extra["ax_mps2"] = ex["ax"][sl] + scale * AX_STD * rng.standard_normal(n)
    return DriveLog(
        t=t.copy(), vx=np.maximum(vx + noise["vx"], VX_FLOOR), delta=truth.delta[sl] + noise["delta"],
        yaw_rate=truth.r[sl] + noise["yaw_rate"], ay=truth.ay[sl] + noise["ay"],
        vy=truth.vy[sl].copy(), Ff=truth.Ff[sl].copy(), Fr=truth.Fr[sl].copy(),
        yL=ex["yL"][sl] + noise["yL"] if has_vision else None,
        psiL=ex["psiL"][sl] + noise["psiL"] if has_vision else None,
        rho=ex["rho"][sl].copy() if "rho" in ex else None,
        extra=extra, source=f"{truth.source} at {rate:g} Hz")
