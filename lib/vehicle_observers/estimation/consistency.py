"""Is this vehicle file this car? A vehicle-log consistency check run before any estimate.

An estimator given another car's vehicle file (or tyres ten times too stiff, or the axle
distances swapped) runs without complaint and returns estimates several times worse than
with the right file. Three checks, each cheap (well under 0.1 s on a 55,000-row log):

1. **The file itself** (no log needed, Pacejka tyres): the friction coefficient per axle
   ``mu = D / F_z`` (``F_z`` the static axle load from ``m``, ``a_f``, ``a_r``), the ratio of
   the two axles' ``mu``, and the cornering-stiffness coefficient ``C / F_z`` [1/rad] per axle
   (``C = B C D`` at zero slip; linear tyres: ``cornering_stiffness``).
2. **The model against the log** (the check of :func:`vehicle_observers.data.identification.
   identify_stiffness`, reused): the single-track model of the file, simulated open loop from
   the measured steering and speed on the log's first stretch in motion (at most
   :data:`WINDOW_S` s, thinned to at most :data:`RATE_HZ`, restarted every :data:`CHUNK_S`
   s from the measured yaw rate), against the measured yaw rate:
   its gain ``k`` (least squares ``r_meas ~ k r_model``) and the unexplained share
   (:func:`~vehicle_observers.data.identification.unexplained_share`); the lateral
   acceleration's unexplained share after the accelerometer's gain (in
   :data:`~vehicle_observers.data.identification.AY_GAIN_BOUNDS`) and offset.
3. **The** ``[uncertainty]`` **speed box against the log** (estimators that read it): rows in
   motion outside ``[vx_min, vx_max]`` are clipped to the box by the interval observers, where
   their bounds are not guaranteed.

Thresholds (each a pair: doubtful -> one warning line; beyond -> refused, exit 2 on the
command line unless ``--accept-mismatch``) were calibrated on the shipped pairs, which must
never be refused -- the Revs log with ``revs250lm`` (its first 120 s, and every 30 s and
120 s segment from 150 to 690 s every 15 s), emulated logs of
:mod:`vehicle_observers.data.scenarios` with ``yacine2015``, the multi-body plant's logs of
:mod:`vehicle_observers.data.plant` (4 manoeuvres x its 3 cars) with each car's data-sheet
file -- and on scrambled files, which must be refused: stiffness x10 (``B`` or ``D``),
``a_f``/``a_r`` swapped, another of these cars. Measured (model restarted every
:data:`CHUNK_S` s): right file: ``k`` 0.73-1.04 (the lowest on Revs segments driven at the
limit; plant and emulated 0.97-1.04), unexplained yaw rate <= 0.50 (Revs segments; plant and
emulated <= 0.10); ``mu`` 0.78-1.3, axle ratio <= 1.11, ``C/F_z`` 5.0-22.8 1/rad.
Scrambled: another car ``k`` 0.53-0.65 (on emulated logs) or 1.46-2.15 (``yacine2015`` on
Revs segments and plant logs) -- except the plant's three cars among themselves, the
plant's cars on Revs and ``revs250lm`` on plant logs, which the data cannot tell apart
(``k`` 0.69-1.24: warned at most); stiffness x10 ``C/F_z`` >= 50 or ``mu`` >= 7.8; axles
swapped ``mu`` ratio 1.48-2.74 (1.30 for the plant's nearly balanced van: warned, and its
model then gives ``k`` 0.06-0.82 on most logs).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehicle_observers.data.identification import (
    AY_GAIN_BOUNDS,
    open_loop_outputs,
    static_axle_loads,
    unexplained_share,
)
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import segments
from vehicle_observers.models.tires import LinearTire
from vehicle_observers.models.vehicle import Vehicle

#: seconds of the first stretch in motion simulated open loop
WINDOW_S = 120.0
#: the window is thinned to at most this rate [Hz] (zero-order-hold inputs: the model's
#: poles are below 30 1/s at the speeds checked, 5 ms steps resolve them)
RATE_HZ = 200.0
#: shortest window [s] and smallest yaw-rate std [rad/s] the model check judges
MIN_WINDOW_S = 2.0
MIN_YAW_STD = 0.01
#: the open-loop model restarts every CHUNK_S seconds from the measured yaw rate (a real car
#: driven at its limit makes any single-track model depart within seconds: 10 s chunks gave
#: the right Revs file k = 0.21 on some segments, 2 s chunks 0.73); the first T_SKIP seconds
#: after each start (v_y = 0 there; the yaw mode settles in about 0.2 s) are left out
CHUNK_S = 2.0
T_SKIP = 0.5

#: yaw-rate gain measured / model: (doubtful, refused) factors either way; right files
#: 0.73-1.04, another car 0.53-0.65 or 1.46-2.15 (module docstring)
YAW_GAIN = (1.25, 1.45)
#: unexplained share of the yaw rate: (doubtful, refused); right files <= 0.50
YAW_UNEXPLAINED = (0.3, 0.75)
#: unexplained share of a_y after its gain and offset: doubtful above (right files <= 0.36)
AY_UNEXPLAINED = 0.5
#: tyre friction D / F_z: (doubtful range, refused outside); identify searches [0.2, 3]
MU_RANGE = ((0.5, 2.0), (0.2, 3.0))
#: ratio of the axles' friction coefficients (larger / smaller): right files <= 1.11,
#: a_f / a_r swapped 1.51-1.55
MU_RATIO = (1.25, 1.4)
#: cornering-stiffness coefficient C / F_z [1/rad]: (doubtful range, refused outside); right
#: files 5.0-22.8, stiffness x10 >= 50, x0.3 <= 2.3 on the softer car
CF_RANGE = ((4.0, 35.0), (2.0, 45.0))
#: share of the rows in motion outside the speed box above which it is refused
BOX_REFUSED = 0.5


@dataclass
class Consistency:
    """Result of :func:`check_vehicle_log`. ``verdict``: ``"ok"``, ``"doubtful"`` (see
    ``doubts``) or ``"mismatch"`` (see ``problems``: the file cannot be this car);
    ``yaw_gain`` measured / model yaw rate, ``yaw_unexplained``, ``ay_unexplained`` (``None``
    when not computed); ``window`` (t0, t1) [s] of the model check; ``box_clipped`` rows in
    motion outside the speed box of ``box_rows`` rows in motion."""

    problems: list = field(default_factory=list)
    doubts: list = field(default_factory=list)
    yaw_gain: float | None = None
    yaw_unexplained: float | None = None
    ay_unexplained: float | None = None
    window: tuple | None = None
    box_clipped: int = 0
    box_rows: int = 0
    vehicle: str = ""

    @property
    def verdict(self) -> str:
        return "mismatch" if self.problems else ("doubtful" if self.doubts else "ok")

    def message(self) -> str:
        """One line: the problems (or the doubts) with their numbers."""
        what = self.problems or self.doubts
        if not what:
            return f"vehicle file {self.vehicle} is consistent with the log"
        head = (f"vehicle file {self.vehicle} cannot be this car: " if self.problems
                else f"vehicle file {self.vehicle} is doubtful for this log: ")
        return head + "; ".join(what)


def tyre_coefficients(vehicle: Vehicle) -> dict:
    """Per axle (``"front"``, ``"rear"``): ``mu = D / F_z`` (``None`` for linear tyres) and
    ``C / F_z`` [1/rad] at the static axle loads."""
    p = vehicle.params
    out = {}
    for axle, tyre, Fz in (("front", p.tire_f, static_axle_loads(p)[0]),
                           ("rear", p.tire_r, static_axle_loads(p)[1])):
        mu = None if isinstance(tyre, LinearTire) else float(tyre.D) / Fz
        out[axle] = {"mu": mu, "cf": float(tyre.cornering_stiffness) / Fz}
    return out


def _file_checks(vehicle: Vehicle, res: Consistency):
    co = tyre_coefficients(vehicle)
    for axle, c in co.items():
        mu, cf = c["mu"], c["cf"]
        if mu is not None:
            (wlo, whi), (rlo, rhi) = MU_RANGE
            if not rlo <= mu <= rhi:
                res.problems.append(f"{axle} tyre peak D / F_z = {mu:.3g} (friction "
                                    f"coefficient; a road tyre has {rlo:g}..{rhi:g}): its D is "
                                    "not for this mass and axle load")
            elif not wlo <= mu <= whi:
                res.doubts.append(f"{axle} tyre peak D / F_z = {mu:.3g} (usual {wlo:g}..{whi:g})")
        (wlo, whi), (rlo, rhi) = CF_RANGE
        if not rlo <= cf <= rhi:
            res.problems.append(f"{axle} cornering stiffness / F_z = {cf:.3g} 1/rad (road tyres "
                                f"{rlo:g}..{rhi:g}): tyres {cf / 15:.2g}x too stiff or soft?")
        elif not wlo <= cf <= whi:
            res.doubts.append(f"{axle} cornering stiffness / F_z = {cf:.3g} 1/rad (usual "
                              f"{wlo:g}..{whi:g})")
    mus = [c["mu"] for c in co.values()]
    if None not in mus:
        ratio = max(mus) / min(mus)
        if ratio > MU_RATIO[1]:
            res.problems.append(f"the axles' friction coefficients differ by x{ratio:.3g} "
                                f"(front {mus[0]:.3g}, rear {mus[1]:.3g} at the static loads of "
                                f"a_f = {vehicle.params.a_f:g}, a_r = {vehicle.params.a_r:g} m; "
                                f"above {MU_RATIO[1]:g}): a_f and a_r swapped?")
        elif ratio > MU_RATIO[0]:
            res.doubts.append(f"the axles' friction coefficients differ by x{ratio:.3g}")


def model_window(log: DriveLog, vehicle: Vehicle, window_s: float = WINDOW_S,
                 max_gap: float = segments.MAX_GAP_S) -> DriveLog | None:
    """The first ``window_s`` seconds of the log's first stretch in motion (the Kalman
    family's stretches, :func:`segments.moving_rows`), thinned to at most :data:`RATE_HZ`;
    ``None`` when that is shorter than :data:`MIN_WINDOW_S`."""
    # the rows in motion of a prefix long enough to hold the window (a 10^7-row log is not
    # scanned whole): from the first row at speed, twice the window, doubled until a stretch
    # is found that ends before the prefix does, or the log ends
    N = len(log)
    fast = np.flatnonzero(log.vx >= segments.V_LOW)
    if not len(fast):
        return None
    span = 2.0 * window_s + 10.0
    while True:
        end = int(np.searchsorted(log.t, log.t[fast[0]] + span, side="right"))
        end = min(max(end, fast[0] + 60), N)
        pre = segments.view(log, 0, end)
        runs, _ = segments.stretches(pre.t, segments.moving_rows(pre, vehicle), max_gap, 50)
        if runs and (runs[0][1] < end or log.t[runs[0][1] - 1] - log.t[runs[0][0]] >= window_s
                     or end == N):
            break
        if end == N:
            return None
        span *= 2.0
    a, b = runs[0]
    n = int(np.searchsorted(log.t[a:b], log.t[a] + window_s, side="right"))
    sub = segments.view(log, a, a + n)
    if len(sub) < 3 or sub.duration < MIN_WINDOW_S:
        return None
    step = max(1, int(round(1.0 / (RATE_HZ * sub.dt))))
    idx = np.arange(0, len(sub), step)
    return DriveLog(t=sub.t[idx], vx=sub.vx[idx], delta=sub.delta[idx],
                    yaw_rate=sub.yaw_rate[idx], ay=None if sub.ay is None else sub.ay[idx],
                    source=sub.source)


def _chunked_open_loop(vehicle: Vehicle, win: DriveLog):
    """Yaw rate and a_y of the open-loop model over ``win``, restarted every
    :data:`CHUNK_S` seconds from ``v_y = 0`` and the measured yaw rate (the first
    :data:`T_SKIP` s of each chunk are NaN; ``judged`` marks the others): a model that spins
    in one hard corner (the right file on a real car at its limit) spoils that chunk only.
    Returns (yaw rate, a_y, judged), each (N,)."""
    n = len(win)
    r_mod, ay_mod = np.full(n, np.nan), np.full(n, np.nan)
    judged = np.zeros(n, bool)
    edges = np.searchsorted(win.t, np.arange(win.t[0], win.t[-1], CHUNK_S))
    edges = np.r_[edges, n]
    for a, b in zip(edges[:-1], edges[1:]):
        if b - a < 3:
            continue
        sub = DriveLog(t=win.t[a:b], vx=win.vx[a:b], delta=win.delta[a:b],
                       yaw_rate=win.yaw_rate[a:b])
        with np.errstate(all="ignore"):
            r, ay = open_loop_outputs(vehicle.params, sub, substeps=4)
        keep = sub.t >= sub.t[0] + T_SKIP
        judged[a:b] = keep
        r_mod[a:b] = np.where(keep, r, np.nan)
        ay_mod[a:b] = np.where(keep, ay, np.nan)
    return r_mod, ay_mod, judged


def _model_checks(log: DriveLog, vehicle: Vehicle, res: Consistency, window_s, max_gap):
    win = model_window(log, vehicle, window_s, max_gap)
    if win is None:
        res.doubts.append(f"the log has no {MIN_WINDOW_S:g} s stretch in motion to check the "
                          "vehicle model on")
        return
    res.window = (float(win.t[0]), float(win.t[-1]))
    if np.std(win.yaw_rate) < MIN_YAW_STD:
        res.doubts.append(f"the log's first {win.duration:.0f} s in motion hold too little yaw "
                          f"(std {np.std(win.yaw_rate):.2g} rad/s) to check the vehicle model")
        return
    r_all, ay_all, judged = _chunked_open_loop(vehicle, win)
    sel = judged & np.isfinite(r_all) & (np.abs(r_all) < 10.0)
    span = f"t = {res.window[0]:.4g}..{res.window[1]:.4g} s"
    if sel.sum() < 0.5 * judged.sum():
        res.problems.append(f"its single-track model diverges on most of the log's first "
                            f"stretch in motion ({span})")
        return
    r_meas, r_mod, ay_mod = win.yaw_rate[sel], r_all[sel], ay_all
    k = float(r_mod @ r_meas / (r_mod @ r_mod)) if r_mod @ r_mod > 0 else float("nan")
    u = unexplained_share(r_mod, r_meas)
    res.yaw_gain, res.yaw_unexplained = k, u
    gain_txt = (f"the measured yaw rate is {k:.3g} x its model's (open loop from the measured "
                f"steering and speed, {span})")
    if not (k > 0 and 1 / YAW_GAIN[1] <= k <= YAW_GAIN[1]):
        res.problems.append(f"{gain_txt}, expected {1 / YAW_GAIN[1]:.2f}..{YAW_GAIN[1]:g}: "
                            "another car's file, or wrong tyres or axle distances?")
    elif u > YAW_UNEXPLAINED[1]:
        res.problems.append(f"its model leaves {100 * u:.0f} % of the yaw rate's spread "
                            f"unexplained ({span}; above {100 * YAW_UNEXPLAINED[1]:.0f} %)")
    elif not 1 / YAW_GAIN[0] <= k <= YAW_GAIN[0]:
        res.doubts.append(f"{gain_txt} (usual {1 / YAW_GAIN[0]:.2f}..{YAW_GAIN[0]:g})")
    elif u > YAW_UNEXPLAINED[0]:
        res.doubts.append(f"its model leaves {100 * u:.0f} % of the yaw rate's spread "
                          f"unexplained ({span})")
    if win.ay is not None:
        a_meas, a_mod = win.ay[sel], ay_mod[sel]
        if np.all(np.isfinite(a_mod)) and np.std(a_mod) > 0:
            A = np.column_stack([a_mod, np.ones(len(a_mod))])
            g = float(np.clip(np.linalg.lstsq(A, a_meas, rcond=None)[0][0], *AY_GAIN_BOUNDS))
            c = float(np.mean(a_meas - g * a_mod))
            res.ay_unexplained = unexplained_share(g * a_mod + c, a_meas)
            if res.ay_unexplained > AY_UNEXPLAINED and not res.problems:
                res.doubts.append(f"its model leaves {100 * res.ay_unexplained:.0f} % of the "
                                  f"lateral acceleration's spread unexplained ({span})")


def _box_checks(log: DriveLog, vehicle: Vehicle, res: Consistency):
    lo, hi = vehicle.uncertainty.get("vx_min"), vehicle.uncertainty.get("vx_max")
    if lo is None or hi is None:
        return
    moving = segments.moving_rows(log)
    v = log.vx[moving]
    out = (v < lo) | (v > hi)
    res.box_rows, res.box_clipped = int(len(v)), int(out.sum())
    if not res.box_clipped:
        return
    share = res.box_clipped / max(res.box_rows, 1)
    below, above = int((v < lo).sum()), int((v > hi).sum())
    where = ", ".join(s for s in (f"{below} below {lo:g} m/s" if below else "",
                                  f"{above} above {hi:g} m/s" if above else "") if s)
    txt = (f"its [uncertainty] speed box [{lo:g}, {hi:g}] m/s excludes {res.box_clipped} of the "
           f"{res.box_rows} rows in motion ({100 * share:.1f} %: {where}; the log's speeds "
           f"{float(v.min()):.3g}..{float(v.max()):.3g} m/s): the interval observers clip "
           "them to the box and their bounds are not guaranteed there")
    (res.problems if share > BOX_REFUSED else res.doubts).append(txt)


def check_vehicle_log(log: DriveLog, vehicle: Vehicle, box: bool = False,
                      window_s: float = WINDOW_S,
                      max_gap: float = segments.MAX_GAP_S) -> Consistency:
    """Check that ``vehicle`` can be the car of ``log`` (module docstring); ``box``: also the
    ``[uncertainty]`` speed box (for estimators that read it). Never raises for a bad
    match: the result says it (:attr:`Consistency.verdict`, :meth:`Consistency.message`)."""
    res = Consistency(vehicle=Path(vehicle.path).name or vehicle.name)
    _file_checks(vehicle, res)
    _model_checks(log, vehicle, res, window_s, max_gap)
    if box:
        _box_checks(log, vehicle, res)
    return res
