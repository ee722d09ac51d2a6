"""Vehicle TOML files: the shipped ones equal the paper constants; errors name the key."""

import pytest
from vehicle_observers.models.tires import LinearTire
from vehicle_observers.models.vehicle import VehicleFileError, builtin_vehicles, load_vehicle
from vehicle_observers_papers.leanza_2021 import constants as R
from vehicle_observers_papers.yacine_2015 import constants as Y


@pytest.mark.parametrize("name, params", [("yacine2015", Y.params), ("revs250lm", R.params)])
def test_shipped_vehicle_files_equal_paper_constants(name, params):
    v = load_vehicle(name)
    for k in ("m", "I_z", "a_f", "a_r", "r_f", "r_r", "l_s"):
        assert getattr(v.params, k) == pytest.approx(getattr(params, k), rel=1e-15)
    for axle in ("tire_f", "tire_r"):
        a, b = getattr(v.params, axle), getattr(params, axle)
        for c in ("B", "C", "D", "E"):
            assert getattr(a, c) == pytest.approx(getattr(b, c), rel=1e-15)
    assert v.uncertainty["stiffness_rel"] == 0.10
    assert v.kalman is None
    assert set(builtin_vehicles()) >= {"yacine2015", "revs250lm"}


def test_revs_file_keeps_the_publishing_repository_stiffness():
    v = load_vehicle("revs250lm")
    assert v.C_f == pytest.approx(0.7e5, rel=1e-12)
    assert v.C_r == pytest.approx(1.2e5, rel=1e-12)


def test_linear_tyres_and_defaults(tmp_path):
    p = tmp_path / "lin.toml"
    p.write_text("m = 1000\nI_z = 1500\na_f = 1.2\na_r = 1.3\n"
                 "[tire_front]\nmodel = \"linear\"\ncornering_stiffness = 5e4\n"
                 "[tire_rear]\nmodel = \"linear\"\ncornering_stiffness = 6e4\n")
    v = load_vehicle(p)
    assert isinstance(v.params.tire_f, LinearTire) and v.C_r == 6e4
    assert (v.params.r_f, v.params.l_s, v.name) == (0.1, 0.5, "lin")
    with pytest.raises(VehicleFileError, match="missing key 'uncertainty.vx_min'"):
        v.need_uncertainty("vx_min")
    p.write_text(p.read_text().replace("a_r = 1.3", "a_r = true"))
    with pytest.raises(VehicleFileError, match=r"lin.toml: key 'a_r' must be a finite number"):
        load_vehicle(p)


def test_special_and_oversized_vehicle_files_refused(tmp_path):
    import os

    fifo = tmp_path / "car.toml"
    os.mkfifo(fifo)
    with pytest.raises(VehicleFileError, match="is a FIFO"):
        load_vehicle(fifo)                 # no writer: reading would block forever
    with pytest.raises(VehicleFileError, match="is a directory"):
        load_vehicle(tmp_path)
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * (2 << 20))
    with pytest.raises(VehicleFileError, match="not a vehicle file"):
        load_vehicle(big)
