"""Selection rule, uncertainty inflation and identifiability verdict: measured channels only."""

from dataclasses import replace

import numpy as np
import pytest
from vehicle_observers.baselines import adaptive as AD
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import get
from vehicle_observers.estimation import selection as SE
from vehicle_observers.models.vehicle import load_vehicle

VEH = load_vehicle("yacine2015")
T = np.arange(1000) * 0.01


def test_batch_means_iact_of_white_and_ar1():
    rng = np.random.default_rng(0)
    w = rng.standard_normal(200_000)
    assert SE.batch_means_iact(w, 50) == pytest.approx(1.0, abs=0.05)
    rho = 0.8                                   # AR(1): iact = (1 + rho)/(1 - rho) = 9
    x = np.empty_like(w)
    x[0] = w[0]
    for k in range(1, len(w)):
        x[k] = rho * x[k - 1] + w[k]
    assert SE.batch_means_iact(x, 200) == pytest.approx(9.0, rel=0.1)


def test_vy_std_floor_and_inflation():
    s = SE.vy_std(np.full(3, 0.01), np.array([0.0, 10.0, 20.0]), 4.0)
    assert s[0] == pytest.approx(0.2)
    assert s[2] ** 2 == pytest.approx(4 * 0.01 + (20 * np.tan(SE.BETA_FLOOR)) ** 2)


def test_verdict_reads_measured_channels_and_own_uncertainty_only():
    log = AD.simulate(VEH.params, T, np.full_like(T, 20.0), 0.03 * np.sin(2 * np.pi * 0.5 * T))
    vy = log.vy.copy()
    std = np.full(len(T), 0.01)
    log.vy = np.full(len(T), 99.0)              # garbage reference: must not matter
    v = SE.verdict(vy, std, log, VEH, True)
    assert v["verdict"] == "informative" and v["signal_to_std"] > 1
    v0 = SE.verdict(0.005 * np.ones(len(T)), std, log, VEH, True)
    assert v0["verdict"] == "uninformative" and "v_y = 0" in v0["line"]
    assert v0["line"].count("\n") == 0


def test_no_ay_and_unidentified_stiffness_is_uninformative():
    """A slow ramp steer seen through the yaw rate only: only the understeer gradient is
    determined, not each axle's stiffness (identify_stiffness says so)."""
    t = np.arange(2000) * 0.01
    log = AD.simulate(VEH.params, t, np.full_like(t, 15.0), 0.01 * t / t[-1])
    log = DriveLog(t=log.t, vx=log.vx, delta=log.delta, yaw_rate=log.yaw_rate)
    v = SE.verdict(np.full(len(t), 0.5), np.full(len(t), 0.01), log, VEH, False)
    assert v["stiffness"] is False and v["verdict"] == "uninformative"
    assert "no a_y" in v["line"]


def test_registered_adaptive_ekf_reports_std_and_verdict():
    veh = replace(VEH, uncertainty={**VEH.uncertainty, "stiffness_rel": 0.1})
    log = AD.simulate(veh.params, T, np.full_like(T, 15.0), 0.03 * np.sin(2 * np.pi * 0.5 * T),
                      bias=0.3)
    tr = get("adaptive-ekf").estimate(log, veh, candidates=("bias",), maxiter=120)
    assert len(tr) == len(log) and tr.causal
    assert np.all(tr["vy_std_mps"] > 0)
    assert tr.info["verdict"] in ("informative", "uninformative")
    assert "bias" in tr.info["terms"]
    cover = np.mean(np.abs(tr["vy_mps"] - log.vy)[100:] <= 2 * tr["vy_std_mps"][100:])
    assert cover > 0.9


def test_vehicle_file_terms_table_fixes_terms(tmp_path):
    from vehicle_observers.models.vehicle import VehicleFileError, builtin_vehicles

    src = builtin_vehicles()["yacine2015"].read_text()
    f = tmp_path / "car.toml"
    f.write_text(src + "\n[terms]\nroll = true\nbias = false\n")
    veh = load_vehicle(f)
    assert veh.terms == {"roll": True, "bias": False}
    log = AD.simulate(veh.params, T, np.full_like(T, 20.0), 0.03 * np.sin(2 * np.pi * 0.5 * T),
                      bias=0.4)
    sel = SE.select(log, veh, window=log, candidates=("bias",), maxiter=60)
    assert sel.terms.roll and not sel.terms.bias          # bias present but switched off
    assert all("bias" not in r["terms"] for r in sel.rows)
    f.write_text(src + "\n[terms]\nrol = true\n")
    with pytest.raises(VehicleFileError, match="terms.rol"):
        load_vehicle(f)
    f.write_text(src + "\n[terms]\nroll = 1\n")
    with pytest.raises(VehicleFileError, match="true or false"):
        load_vehicle(f)
