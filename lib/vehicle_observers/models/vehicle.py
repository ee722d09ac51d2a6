"""Vehicle files (TOML): the constants every observer needs, with errors that name the key.

Format (SI units; see ``vehicles/yacine2015.toml`` and ``vehicles/revs250lm.toml``)::

    name = "My car"
    m = 1500.0      # kg                 (required)
    I_z = 2454.0    # kg m^2             (required)
    a_f = 1.1       # m, CG-front axle   (required)
    a_r = 1.44      # m, CG-rear axle    (required)
    r_f = 0.1       # m, relaxation      (optional, default 0.1)
    r_r = 0.1       # m                  (optional, default 0.1)
    l_s = 0.5       # m, vision look-ahead (optional, default 0.5)
    stiffness_speed = 0.0   # s/m, C(v_x) = C (1 + k v_x) on both axles (optional, default 0;
                            # kalman.fit_stiffness_speed identifies it from measured channels)

    [tire_front]    # per axle (required); model = "pacejka" (B [1/rad], C, D [N], E)
    model = "pacejka"   # or model = "linear" with cornering_stiffness [N/rad]
    ...
    [tire_rear]     # same keys

    [uncertainty]   # optional: box for interval / robust observers
    stiffness_rel = 0.1   # relative half-width of the cornering-stiffness box
    vx_min = 0.2          # m/s
    vx_max = 17.0         # m/s
    slip_max_deg = 8.0    # deg

    [kalman]        # optional: fixed EKF/UKF noise (else tuned by ML on the log)
    q_vy = ...; q_r = ...; q_b = ...; R_r = ...; R_ay = ...

    [terms]         # optional: model terms of the adaptive EKF (true / false; absent: the
    roll = true     # selection rule decides): roll, bias, bank, stiffness, blend

Bad files raise :class:`VehicleFileError` with the file name and the key, e.g.
``revs.toml: key 'tire_front.D' must be a number > 0, got -3``. Unknown keys (a typo such as
``ls = 3.0``) are errors, and every constant must lie in the plausible range of a road
vehicle (:data:`RANGES`, e.g. ``m`` in [50, 1e5] kg, ``I_z`` in [10, 1e6] kg m^2).
"""

from __future__ import annotations

import math
import stat
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
import tomllib

from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire, Pacejka

#: Index of each noise parameter in :meth:`KalmanTuning.theta` (the vector the Kalman
#: kernels of :mod:`vehicle_observers.baselines.kalman` read)
Q_VY, Q_R, Q_B, R_R, R_AY = range(5)
N_THETA = 5


@dataclass(frozen=True)
class KalmanTuning:
    """Noise parameters (continuous-time process intensities, discrete measurement variances).

    q_vy [(m/s^2)^2 s], q_r [(rad/s^2)^2 s], q_b [(m/s^3)^2 s]: white-noise intensities on
    v_y', r', b_ay'. R_r [(rad/s)^2], R_ay [(m/s^2)^2]: measurement noise variances.
    P0: initial covariance diagonal of ``[v_y, r, b_ay]`` (the v_y entry is capped at
    ``(0.05 v_x(0))^2``, see :func:`_p0`).
    """

    q_vy: float = 0.5
    q_r: float = 0.05
    q_b: float = 0.01
    R_r: float = 1e-4
    R_ay: float = 0.25
    P0: tuple = (1.0, 0.01, 1.0)
    source: str = field(default="sensor-spec defaults", compare=False)

    def theta(self) -> np.ndarray:
        """The packed vector the Kalman kernels read, laid out by :data:`Q_VY`, :data:`Q_R`,
        :data:`Q_B`, :data:`R_R`, :data:`R_AY`."""
        th = np.empty(N_THETA)
        th[Q_VY], th[Q_R], th[Q_B], th[R_R], th[R_AY] = (self.q_vy, self.q_r, self.q_b,
                                                          self.R_r, self.R_ay)
        return th

    @classmethod
    def from_theta(cls, th, source="", P0=(1.0, 0.01, 1.0)):
        th = [float(v) for v in th]
        return cls(q_vy=th[Q_VY], q_r=th[Q_R], q_b=th[Q_B], R_r=th[R_R], R_ay=th[R_AY],
                   P0=tuple(P0), source=source)



class VehicleFileError(ValueError):
    """A vehicle TOML file is unreadable or inconsistent (message names the key)."""


@dataclass(frozen=True)
class Vehicle:
    """A loaded vehicle file. ``params`` for the lateral models; ``uncertainty`` the box
    (``stiffness_rel``, ``vx_min``, ``vx_max`` [m/s], ``slip_max_deg``); ``kalman`` fixed
    noise tuning or ``None``; ``path`` the file."""

    name: str
    params: LateralParams
    uncertainty: dict = field(default_factory=dict)
    kalman: KalmanTuning | None = None
    path: str = ""
    terms: dict = field(default_factory=dict)

    @property
    def C_f(self) -> float:
        """Front cornering stiffness at zero slip [N/rad]."""
        return float(self.params.tire_f.cornering_stiffness)

    @property
    def C_r(self) -> float:
        return float(self.params.tire_r.cornering_stiffness)

    def need_uncertainty(self, *keys, purpose=""):
        """The ``[uncertainty]`` values ``keys`` (raises naming the first missing one)."""
        out = []
        for k in keys:
            if k not in self.uncertainty:
                why = f" ({purpose} needs it)" if purpose else ""
                raise VehicleFileError(f"{Path(self.path).name or self.name}: missing key "
                                       f"'uncertainty.{k}'{why}")
            out.append(self.uncertainty[k])
        return out


def builtin_vehicles() -> dict[str, Path]:
    """Vehicle files shipped with the package: ``{stem: path}``."""
    d = resources.files("vehicle_observers.models") / "vehicles"
    return {p.name[:-5]: Path(str(p)) for p in d.iterdir() if p.name.endswith(".toml")}


#: keys a vehicle file may hold (anything else is an error: a typo such as ``ls = 3.0`` must
#: not be ignored silently)
TOP_KEYS = ("name", "m", "I_z", "a_f", "a_r", "r_f", "r_r", "l_s", "tire_front", "tire_rear",
            "uncertainty", "kalman", "terms", "stiffness_speed")
#: keys of the optional ``[terms]`` table (booleans; vehicle_observers.baselines.adaptive)
TERM_KEYS = ("roll", "bias", "bank", "stiffness", "blend")
TYRE_KEYS = {"pacejka": ("model", "B", "C", "D", "E"),
             "linear": ("model", "cornering_stiffness")}
#: plausible range of each constant of a road vehicle (SI units); outside it the file is
#: refused naming the key (absurd values such as ``I_z = 1e-300`` or ``m = 1e300`` make the
#: models overflow or the LMIs meaningless)
RANGES = {"m": (50.0, 1e5), "I_z": (10.0, 1e6), "a_f": (0.1, 10.0), "a_r": (0.1, 10.0),
          "r_f": (0.0, 5.0), "r_r": (0.0, 5.0), "l_s": (0.0, 100.0),
          "stiffness_speed": (-0.05, 0.05),
          "B": (0.1, 100.0), "C": (0.1, 5.0), "D": (10.0, 1e6), "E": (-20.0, 1.0),
          "cornering_stiffness": (100.0, 1e7),
          "uncertainty.vx_min": (0.01, 150.0), "uncertainty.vx_max": (0.1, 150.0),
          "uncertainty.slip_max_deg": (0.1, 45.0), "kalman.q_vy": (0.0, 1e6),
          "kalman.q_r": (0.0, 1e6), "kalman.q_b": (0.0, 1e6), "kalman.R_r": (0.0, 1e6),
          "kalman.R_ay": (0.0, 1e6)}


def _in_range(v, key, fname):
    lo, hi = RANGES.get(key, RANGES.get(key.split(".")[-1], (-math.inf, math.inf)))
    if not lo <= v <= hi:
        raise VehicleFileError(f"{fname}: key '{key}' = {v:g} is outside the plausible range "
                               f"[{lo:g}, {hi:g}] for a road vehicle (SI units)")
    return v


def _unknown_keys(table: dict, allowed, fname, prefix=""):
    for k in table:
        if k not in allowed:
            raise VehicleFileError(f"{fname}: unknown key '{prefix}{k}' (expected one of "
                                   f"{', '.join(allowed)})")


def _num(doc, key, fname, positive=True, default=None, allow_zero=False):
    parts = key.split(".")
    cur = doc
    for p in parts:
        if not isinstance(cur, dict) or p not in cur:
            if default is not None:
                return float(default)
            raise VehicleFileError(f"{fname}: missing key '{key}'")
        cur = cur[p]
    if isinstance(cur, bool) or not isinstance(cur, (int, float)) or not math.isfinite(cur):
        raise VehicleFileError(f"{fname}: key '{key}' must be a finite number, got {cur!r}")
    v = float(cur)
    if positive and not (v > 0 or (allow_zero and v == 0)):
        rel = ">= 0" if allow_zero else "> 0"
        raise VehicleFileError(f"{fname}: key '{key}' must be a number {rel}, got {cur!r}")
    return _in_range(v, key, fname)


def _tyre(doc, sect, fname):
    if sect not in doc:
        raise VehicleFileError(f"{fname}: missing table '[{sect}]' (tyre of that axle)")
    t = doc[sect]
    if not isinstance(t, dict):
        raise VehicleFileError(f"{fname}: key '{sect}' must be a table")
    model = t.get("model", "pacejka")
    if model in TYRE_KEYS:
        _unknown_keys(t, TYRE_KEYS[model], fname, f"{sect}.")
    if model == "pacejka":
        E = _num(doc, f"{sect}.E", fname, positive=False, default=0.0)
        if E >= 1.0:
            raise VehicleFileError(f"{fname}: key '{sect}.E' must be < 1, got {E}")
        return Pacejka(B=_num(doc, f"{sect}.B", fname), C=_num(doc, f"{sect}.C", fname),
                       D=_num(doc, f"{sect}.D", fname), E=E)
    if model == "linear":
        return LinearTire(_num(doc, f"{sect}.cornering_stiffness", fname))
    raise VehicleFileError(f"{fname}: key '{sect}.model' must be \"pacejka\" or \"linear\", "
                           f"got {model!r}")


#: largest vehicle file read [bytes] (a vehicle file is a few hundred bytes)
MAX_FILE_BYTES = 1 << 20


def load_vehicle(path) -> Vehicle:
    """Read and validate a vehicle TOML file (or a built-in name such as ``"revs250lm"``)."""
    p = Path(path)
    if not p.exists() and str(path) in builtin_vehicles():
        p = builtin_vehicles()[str(path)]
    fname = p.name
    if not p.exists():
        raise VehicleFileError(f"{p}: no such vehicle file (built-in: "
                               f"{', '.join(sorted(builtin_vehicles()))})")
    mode = p.stat().st_mode
    if not stat.S_ISREG(mode):
        what = ("a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)"
                if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "not a regular file")
        raise VehicleFileError(f"{p}: is {what}, expected a vehicle TOML file (a pipe or device "
                               "is not read: it could block forever)")
    if p.stat().st_size > MAX_FILE_BYTES:
        raise VehicleFileError(f"{fname}: {p.stat().st_size} bytes, not a vehicle file (at most "
                               f"{MAX_FILE_BYTES} bytes)")
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise VehicleFileError(f"{fname}: cannot read ({exc})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise VehicleFileError(f"{fname}: not valid TOML ({exc})") from exc
    _unknown_keys(doc, TOP_KEYS, fname)
    name = doc.get("name", p.stem)
    if not isinstance(name, str):
        raise VehicleFileError(f"{fname}: key 'name' must be a string, got {name!r}")
    m = _num(doc, "m", fname)
    Iz = _num(doc, "I_z", fname)
    af = _num(doc, "a_f", fname)
    ar = _num(doc, "a_r", fname)
    rf = _num(doc, "r_f", fname, default=0.1)
    rr = _num(doc, "r_r", fname, default=0.1)
    ls = _num(doc, "l_s", fname, default=0.5)
    ks = _num(doc, "stiffness_speed", fname, positive=False, default=0.0)
    tf = _tyre(doc, "tire_front", fname)
    tr = _tyre(doc, "tire_rear", fname)
    params = LateralParams(m=m, I_z=Iz, a_f=af, a_r=ar, tire_f=tf, tire_r=tr, r_f=rf, r_r=rr,
                           l_s=ls, name=name, stiffness_speed=ks)
    unc = {}
    if "uncertainty" in doc:
        u = doc["uncertainty"]
        if not isinstance(u, dict):
            raise VehicleFileError(f"{fname}: key 'uncertainty' must be a table")
        for k in u:
            if k not in ("stiffness_rel", "vx_min", "vx_max", "slip_max_deg"):
                raise VehicleFileError(f"{fname}: unknown key 'uncertainty.{k}' (expected "
                                       "stiffness_rel, vx_min, vx_max, slip_max_deg)")
            unc[k] = _num(doc, f"uncertainty.{k}", fname, allow_zero=(k == "stiffness_rel"))
        if "stiffness_rel" in unc and unc["stiffness_rel"] >= 1:
            raise VehicleFileError(f"{fname}: key 'uncertainty.stiffness_rel' must be < 1, got "
                                   f"{unc['stiffness_rel']}")
        if "vx_min" in unc and "vx_max" in unc and unc["vx_min"] >= unc["vx_max"]:
            raise VehicleFileError(f"{fname}: key 'uncertainty.vx_min' ({unc['vx_min']}) must "
                                   f"be < 'uncertainty.vx_max' ({unc['vx_max']})")
    kal = None
    if "kalman" in doc:
        if not isinstance(doc["kalman"], dict):
            raise VehicleFileError(f"{fname}: key 'kalman' must be a table")
        keys = ("q_vy", "q_r", "q_b", "R_r", "R_ay")
        for k in doc["kalman"]:
            if k not in keys:
                raise VehicleFileError(f"{fname}: unknown key 'kalman.{k}' (expected "
                                       f"{', '.join(keys)})")
        vals = [_num(doc, f"kalman.{k}", fname, allow_zero=(k == "q_b")) for k in keys]
        kal = KalmanTuning.from_theta(vals, source=f"{fname} [kalman]")
    terms = doc.get("terms", {})
    if not isinstance(terms, dict):
        raise VehicleFileError(f"{fname}: key 'terms' must be a table")
    for k, v in terms.items():
        if k not in TERM_KEYS:
            raise VehicleFileError(f"{fname}: unknown key 'terms.{k}' (expected "
                                   f"{', '.join(TERM_KEYS)})")
        if not isinstance(v, bool):
            raise VehicleFileError(f"{fname}: key 'terms.{k}' must be true or false, got {v!r}")
    return Vehicle(name=name, params=params, uncertainty=unc, kalman=kal, path=str(p),
                   terms=dict(terms))
