"""Helpers of the campaign tests: a tiny campaign, free ports, bit-level table comparison,
processes killed by pid."""

from __future__ import annotations

import os
import socket
import sys
import time
from pathlib import Path

import numpy as np

#: 4 estimators (2 named + the 2 references) x 2 LPV cars x 2 vehicle files x 2 bias cases x 2
#: repetitions = 64 simulations in 22 batches, plus a 2-point LMI map. interval-ifqir2017 is
#: infeasible for the BMW (oversteering box): 8 failing tasks, recorded.
TINY = {
    "name": "tiny", "seed": 7, "repetitions": 2, "batch_size": 3,
    "estimators": ["ekf", "interval-ifqir2017"],
    "truth": {"plants": ["lpv:yacine2015", "lpv:bmw_320i"],
              "manoeuvres": [{"name": "slalom", "duration": 6.0, "vx": 12.0}]},
    "observer": {"stiffness_rel": [0.1], "speed_range": [[5.0, 20.0]]},
    "errors": {"stiffness": [0.15]},
    "sensors": {"distribution": "uniform", "std": {"vx": 0.0},
                "bias": [{}, {"yaw_rate": 0.01}]},
    "lmi_map": {"cars": ["yacine2015"], "stiffness_rel": [0.05, 0.3],
                "speed_range": [[5.0, 20.0]], "kappa": [0.0], "batch_size": 1},
}
ROOT = Path(__file__).resolve().parents[2]


def subprocess_env() -> dict:
    """Environment of child processes: this checkout's library first on the path, thread
    counts pinned (what a user sets for `dask worker`)."""
    from vehicle_observers.campaign.tasks import THREAD_ENV

    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "lib"), env.get("PYTHONPATH", "")])
    env.update(THREAD_ENV)
    return env


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def same_bits(a, b) -> list[str]:
    """Columns where two pyarrow tables differ (floats compared bit for bit: NaN == NaN of
    the same payload, -0.0 != 0.0)."""
    bad = []
    if a.column_names != b.column_names or a.num_rows != b.num_rows:
        return [f"shape {a.column_names} x {a.num_rows} != {b.column_names} x {b.num_rows}"]
    for n in a.column_names:
        x, y = a[n].to_numpy(zero_copy_only=False), b[n].to_numpy(zero_copy_only=False)
        if x.dtype.kind == "f":
            same = np.array_equal(x.view(np.uint64), y.view(np.uint64))
        else:
            same = list(x) == list(y)
        if not same:
            bad.append(n)
    return bad


def kill_tree(pid: int):
    """SIGKILL a process we started and its children, by pid."""
    import psutil

    try:
        p = psutil.Process(pid)
        kids = p.children(recursive=True)
    except psutil.NoSuchProcess:
        return
    for q in [p, *kids]:
        try:
            q.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs([p, *kids], timeout=10)


def wait_for(pred, timeout: float, what: str, step: float = 0.05):
    t0 = time.monotonic()
    while not pred():
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(f"waited {timeout} s for {what}")
        time.sleep(step)



PY = sys.executable

#: a campaign that lasts a few seconds (the plug-in sleeps per simulation): 40 simulations
#: in 20 batches, killed mid-run by the tests
SLOW = {
    "name": "slow", "seed": 3, "repetitions": 10, "batch_size": 2, "plugins": ["campaign_plugin"],
    "estimators": ["test-slow", "test-diverges"], "references": [],
    "truth": {"plants": ["lpv:bmw_320i"], "manoeuvres": [{"name": "slalom", "duration": 4.0}]},
    "errors": {"mass": [0.1]},
}


def plugin_env(sleep: float) -> dict:
    """:func:`subprocess_env` with this folder on the path (the plug-in module) and the
    plug-in's sleep per simulation [s]."""
    env = subprocess_env()
    env["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).parent), env["PYTHONPATH"]])
    env["CAMPAIGN_TEST_SLEEP"] = str(sleep)
    return env
