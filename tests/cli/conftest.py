"""Small generated drive logs for the command-line tests (emulated truth from the Yacine 2015
model, :func:`scenarios.replay`, with the package's sensor noise)."""

import numpy as np
import pytest
from vehicle_observers.data.logs import DriveLog, write_csv
from vehicle_observers.data.scenarios import replay

#: the columns a user's log has (measured channels + reference v_y + vision)
USER_COLUMNS = ("t_s", "vx_mps", "delta_roadwheel_rad", "yaw_rate_radps", "ay_mps2", "vy_mps",
                "yL_m", "psiL_rad")
#: noise tuning of the yacine2015 car's emulated sensors (a [kalman] table: no ML in most tests)
KALMAN = "\n[kalman]\nq_vy = 0.05\nq_r = 0.05\nq_b = 0.01\nR_r = 1e-5\nR_ay = 0.01\n"


@pytest.fixture(autouse=True)
def _tuning_cache(tmp_path, monkeypatch):
    """Each test gets its own (empty) ML-tuning cache."""
    monkeypatch.setenv("VEHICLE_OBSERVERS_CACHE", str(tmp_path / "cache"))


def speed_profile(t, stops=((0.0, 3.0), (28.0, 32.0), (57.0, 60.0)), v=15.0, ramp=5.0):
    """Speed [m/s]: 0 inside each ``stops`` window, ``v`` away from them, linear ramps of
    ``ramp`` s in between (standstill at both ends and a stop in the middle)."""
    d = np.full_like(t, np.inf)
    for a, b in stops:
        d = np.minimum(d, np.where(t < a, a - t, np.where(t > b, t - b, 0.0)))
    return v * np.clip(d / ramp, 0.0, 1.0)


def emulate(T=60.0, fs=100.0, seed=0, profile=speed_profile, noise_scale=1.0) -> DriveLog:
    """A log of ``T`` s at ``fs`` Hz: ``profile(t)`` speed, sinusoidal steering faded in above
    5 m/s, truth from :func:`replay` (the model is simulated at >= 0.3 m/s; the steering is
    zero below 5 m/s, so the truth is ``v_y = 0`` at standstill). Measured ``v_x`` is the
    profile itself (exactly 0 at rest)."""
    t = np.arange(0.0, T, 1.0 / fs)
    vx = profile(t)
    gate = np.clip((vx - 5.0) / 3.0, 0.0, 1.0)
    delta = 0.05 * np.sin(2 * np.pi * 0.25 * t) * gate
    base = DriveLog(t=t, vx=vx, delta=delta, yaw_rate=np.zeros_like(t), rho=np.zeros_like(t),
                    extra={"vx_true_mps": np.maximum(vx, 0.3), "delta_true_rad": delta},
                    source="emulated")
    log = replay(base, seed=seed, noise_scale=noise_scale, substeps=4)
    # second pass: the road curvature is the car's path curvature r / v_x (v_y, r do not
    # depend on it), so the vision channels stay those of a car in its lane
    base.rho = log.extra["yaw_rate_true_radps"] / np.maximum(vx, 0.3)
    log = replay(base, seed=seed, noise_scale=noise_scale, substeps=4)
    log.vx = vx.copy()
    return log


def take(log: DriveLog, idx) -> DriveLog:
    """The rows ``idx`` (index or bool array) of the schema channels of ``log``."""
    kw = {a: (None if getattr(log, a) is None else getattr(log, a)[idx]) for a in
          ("t", "vx", "delta", "yaw_rate", "ay", "vy", "yL", "psiL", "Ff", "Fr", "rho")}
    return DriveLog(**kw, source=log.source)


def save(log: DriveLog, path, columns=USER_COLUMNS, edit=None):
    """Write the user columns of ``log``; ``edit(cols)`` may change them first."""
    cols = {c: log.columns()[c].copy() for c in columns}
    if edit is not None:
        edit(cols)
    write_csv(path, cols)
    return path


@pytest.fixture(scope="session")
def stopgo():
    """60 s at 100 Hz: standstill 0-3 s, stop 28-32 s, standstill 57-60 s."""
    return emulate()


@pytest.fixture(scope="session")
def vehicle_file(tmp_path_factory):
    from vehicle_observers.models.vehicle import builtin_vehicles

    p = tmp_path_factory.mktemp("veh") / "car.toml"
    p.write_text(builtin_vehicles()["yacine2015"].read_text() + KALMAN)
    return p
