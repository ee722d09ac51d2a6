"""A plug-in module of the campaign tests (named in a spec's ``plugins``, imported on every
worker): ``test-slow`` sleeps ``$CAMPAIGN_TEST_SLEEP`` seconds and returns the open-loop
linear bicycle (so a campaign lasts long enough to be killed mid-run; the sleep changes no
number), ``test-diverges`` returns NaN after the first second when the vehicle file's mass is
wrong (a diverged filter, to be recorded as a failed task), ``test-hangs`` never returns
while ``$CAMPAIGN_TEST_HANG`` is set (else it is ``test-slow``);
importing it makes the truth of a 5.5 s slalom fail (no other manoeuvre is touched)."""

from __future__ import annotations

import os
import time

import numpy as np
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.estimation.registry import estimator, get


@estimator("test-slow", "open-loop linear bicycle after a sleep (tests)")
def slow(log, vehicle, **_):
    time.sleep(float(os.environ.get("CAMPAIGN_TEST_SLEEP", "0")))
    tr = get("open-loop-linear").run(log, vehicle)
    return Trajectory(log.t, tr.x[:, :2], tr.names[:2], estimator="test-slow")


@estimator("test-diverges", "v_y = 0, NaN from t = 1 s when the mass is not the car's (tests)")
def diverges(log, vehicle, **_):
    x = np.zeros((len(log), 2))
    if vehicle.params.m > 1100.0:
        x[log.t - log.t[0] > 1.0, 0] = np.nan
    return Trajectory(log.t, x, ("vy_mps", "yaw_rate_radps"), estimator="test-diverges")


@estimator("test-hangs", "never returns while $CAMPAIGN_TEST_HANG is set (tests)")
def hangs(log, vehicle, **_):
    while os.environ.get("CAMPAIGN_TEST_HANG"):     # only in the timeout tests: every other
        time.sleep(0.01)                             # test of the process may run it
    return slow(log, vehicle)


# a truth that cannot be simulated: the slalom of 5.5 s fails inside the plant (tests of the
# engines' agreement when a truth fails; the spec check cannot see it)
from vehicle_observers.campaign import truths as _truths  # noqa: E402

_simulate = _truths.simulate_truth


def _failing_truth(plant, car, man, rate=None):
    if dict(man[1]).get("duration") == 5.5:
        raise RuntimeError("plant diverged at t = 0.3 s (planted by the tests)")
    return _simulate(plant, car, man, rate)


_truths.simulate_truth = _failing_truth
