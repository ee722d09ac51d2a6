"""Scores of an estimate against the reference columns a log has (benchmark metrics)."""

from __future__ import annotations

import numpy as np

from vehicle_observers.core.metrics import enclosure_rate, max_abs, rmse
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import segments


def score(est: Trajectory, log: DriveLog, mask=None) -> dict:
    """Benchmark metrics of ``est`` against the reference columns the log has.

    vy (``vy_mps``) and sideslip (atan2(vy, vx), on rows with ``v_x >= V_LOW`` only) RMSE /
    max error; yaw rate against the
    log's yaw-rate truth (``yaw_rate_true_radps`` in emulated logs) or the measured
    channel; axle forces when the log has ``Ff_N``/``Fr_N``; for interval observers the
    enclosure rate and mean width of vy and yaw rate. ``mask`` (N,) bool restricts the
    samples. Keys: ``rmse_vy``, ``max_vy``, ``rmse_beta``, ``max_beta``, ``rmse_r``,
    ``max_r``, ``rmse_Ff``, ``rmse_Fr``, ``max_Ff``, ``max_Fr``, ``enclosure_vy``,
    ``width_vy``, ``enclosure_r``, ``width_r``; absent where not computable.
    """
    m = np.ones(len(log), bool) if mask is None else np.asarray(mask, bool)
    out = {}
    c = est.columns
    if log.vy is not None and "vy_mps" in c:
        out["rmse_vy"] = rmse(c["vy_mps"], log.vy, m)
        out["max_vy"] = max_abs(c["vy_mps"], log.vy, m)
        b_ref = np.arctan2(log.vy, log.vx)
        b_est = c.get("beta_rad", np.arctan2(c["vy_mps"], log.vx))
        mb = m & (log.vx >= segments.V_LOW)   # sideslip undefined at standstill
        if mb.any():
            out["rmse_beta"] = rmse(b_est, b_ref, mb)
            out["max_beta"] = max_abs(b_est, b_ref, mb)
    r_ref = log.extra.get("yaw_rate_true_radps", log.yaw_rate)
    if "yaw_rate_radps" in c:
        out["rmse_r"] = rmse(c["yaw_rate_radps"], r_ref, m)
        out["max_r"] = max_abs(c["yaw_rate_radps"], r_ref, m)
    for ax in ("Ff", "Fr"):
        ref = getattr(log, ax)
        if ref is not None and f"{ax}_N" in c:
            out[f"rmse_{ax}"] = rmse(c[f"{ax}_N"], ref, m)
            out[f"max_{ax}"] = max_abs(c[f"{ax}_N"], ref, m)
    for key, ref, nm in (("vy", log.vy, "vy_{}_mps"), ("r", r_ref, "yaw_rate_{}_radps")):
        lo, hi = c.get(nm.format("lo")), c.get(nm.format("hi"))
        if lo is not None and hi is not None and ref is not None:
            out[f"enclosure_{key}"] = enclosure_rate(lo[m], ref[m], hi[m])
            out[f"width_{key}"] = float(np.mean((hi - lo)[m]))
    return out
