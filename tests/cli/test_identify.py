"""``python -m vehicle_observers identify``: writes a vehicle file the other commands accept
from a plant log, and refuses (exit 2, no file) when only a combination is identifiable."""

from __future__ import annotations

import pytest
from vehicle_observers.cli import main as cli
from vehicle_observers.data import plant
from vehicle_observers.models.vehicle import load_vehicle

P = plant.nominal_params()
GEOM = ["--mass", str(P.m), "--inertia", str(P.I_z), "--a-f", str(P.a_f), "--a-r", str(P.a_r)]


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    out = {}
    for n in ("slalom", "ramp_steer"):
        out[n] = d / f"{n}.csv"
        plant.plant_log(n, seed=2, quick=True).to_csv(out[n])
    return out


def test_identify_writes_vehicle_file_accepted_by_estimate(logs, tmp_path, capsys):
    car = tmp_path / "car.toml"
    assert cli.main(["identify", str(logs["slalom"]), "--out", str(car), *GEOM]) == 0
    text = capsys.readouterr().out
    assert "C_f = " in text and "95% CI" in text
    v = load_vehicle(car)
    assert v.C_f == pytest.approx(P.tire_f.cornering_stiffness, rel=0.10)
    assert v.C_r == pytest.approx(P.tire_r.cornering_stiffness, rel=0.10)
    est = tmp_path / "est.csv"
    rc = cli.main(["estimate", str(logs["slalom"]), "--vehicle", str(car), "--observer",
                   "interval-coordinates", "--out", str(est), "--no-progress"])
    assert rc == 0 and est.exists()


def test_identify_refuses_when_not_identifiable(logs, tmp_path, capsys):
    car = tmp_path / "car.toml"
    rc = cli.main(["identify", str(logs["ramp_steer"]), "--out", str(car), *GEOM,
                   "--channels", "yaw_rate"])
    assert rc == cli.EXIT_INPUT and not car.exists()
    err = capsys.readouterr().err
    assert err.startswith("error: NOT identifiable") and "combination" in err


def test_identify_bad_input_one_line(tmp_path, capsys):
    rc = cli.main(["identify", str(tmp_path / "none.csv"), "--out", str(tmp_path / "x.toml"),
                   *GEOM])
    assert rc == cli.EXIT_INPUT
    assert capsys.readouterr().err.count("\n") == 1
