"""Interval observer through a change of coordinates (Raissi, Efimov, Zolghadri 2012;
Mazenc & Bernard 2011): exact transformed bounds, certificate for cars the original design
refuses (neutral-steer box of the CommonRoad BMW, an oversteering car, every shipped car),
and the enclosure guarantee as property tests."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import Observer, run_readable
from vehicle_observers.data import plant
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.models.vehicle import builtin_vehicles, load_vehicle
from vehicle_observers.observers import interval as iv
from vehicle_observers.observers import interval_coordinates as ic

DT = 0.01
P = plant.nominal_params()
BMW = ub.UncertainBicycle(P.m, P.I_z, P.a_f, P.a_r, P.tire_f.cornering_stiffness,
                          P.tire_r.cornering_stiffness, 0.10, name="CommonRoad BMW 320i")
BANDS = ub.SpeedBands((5.0, 12.0, 24.0, 40.0))
# an oversteering car (c_f l_f > c_r l_r on the whole box; critical speed about 47 m/s,
# above the top band edge so the plant is stable on every band)
OVER = ub.UncertainBicycle(1200.0, 1800.0, 1.3, 1.0, 8e4, 9e4, 0.10, name="oversteer")


@pytest.fixture(scope="module")
def bmw_design():
    return ic.design(BMW, BANDS, DT, kappas=(-0.1,))


def test_the_original_design_refuses_the_plant_car():
    """The finding: with C = [0 1] the plant car's +-10 % box straddles neutral steer."""
    assert BMW.max_metzler_uncertainty() < 0.10
    with pytest.raises(InfeasibleDesign, match="Metzler condition"):
        iv.design_theorem2(ub.SwitchedIntervalModel(BMW, BANDS), epsilon_shift=1 / DT)


def test_transformed_matrices_are_similar_and_bounds_exact():
    m = ub.TransformedIntervalModel(BMW, BANDS, 0.2)
    T, Ti = ub.transform(0.2)
    np.testing.assert_allclose(T @ Ti, np.eye(2), atol=1e-15)
    np.testing.assert_allclose(m.C, [[0.2, 1.0]])
    box = BMW.xi_box
    corners = [(a, b) for a in box[0] for b in box[1]]
    for i in range(BANDS.n_modes):
        for j in range(4):
            s, v = m.z_vertices[i, j]
            Az = np.array([T @ ub.lpv_A(s, v, c, BMW) @ Ti for c in corners])
            np.testing.assert_allclose(Az.min(axis=0), m.A_lo[i, j], rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(Az.max(axis=0), m.A_hi[i, j], rtol=1e-12, atol=1e-9)
            # similarity: same eigenvalues as A at the box centre
            ev = np.sort_complex(np.linalg.eigvals(ub.lpv_A(s, v, BMW.xi0, BMW)))
            np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(m.A_nom[i, j])), ev,
                                       rtol=1e-9)


def test_box_image_is_tight_and_contains_members():
    rng = np.random.default_rng(0)
    S = np.array([[1.0, 0.0], [-0.3, 1.0]])
    lo, hi = np.array([-1.0, -0.2]), np.array([2.0, 0.5])
    zlo, zhi = ic.box_image(S, lo, hi)
    X = lo + rng.random((5000, 2)) * (hi - lo)
    Z = X @ S.T
    assert np.all(Z >= zlo - 1e-12) and np.all(Z <= zhi + 1e-12)
    corners = np.array([[a, b] for a in (lo[0], hi[0]) for b in (lo[1], hi[1])]) @ S.T
    np.testing.assert_allclose(corners.min(axis=0), zlo)
    np.testing.assert_allclose(corners.max(axis=0), zhi)


def test_certified_for_plant_car_and_certificate_is_independent(bmw_design):
    d = bmw_design
    assert d.certified and d.kappa == -0.1
    cert = d.design.solution.certificate
    assert cert.ok and cert.min_margin > 0
    assert d.design.min_metzler_margin >= 0
    # the certificate re-computes eigenvalues: a gain that breaks Metzler is caught
    L = d.design.L.copy()
    L[..., 1, 0] -= 1e3      # entry (2,1) = A_z21 - kappa l_2 with kappa < 0
    with pytest.raises(CertificationError, match="not Metzler"):
        iv.certify_metzler(d.design.model, L)


def test_oversteering_car_gets_a_certified_observer():
    assert OVER.max_metzler_uncertainty() == 0.0
    d = ic.design(OVER, BANDS, DT, kappas=(0.0, -0.1))
    assert d.certified and d.kappa != 0.0
    assert "Metzler condition" in d.tried[0.0]


@pytest.mark.parametrize("name", sorted(builtin_vehicles()))
def test_every_shipped_car_certified(name):
    v = load_vehicle(name)
    p = v.params
    veh = ub.UncertainBicycle(p.m, p.I_z, p.a_f, p.a_r, v.C_f, v.C_r,
                              v.uncertainty["stiffness_rel"], name=v.name)
    bands = ub.SpeedBands(tuple(np.geomspace(max(v.uncertainty["vx_min"], 1.0),
                                             v.uncertainty["vx_max"], 4)))
    d = ic.design(veh, bands, DT, kappas=(0.0, -0.1, 0.2))
    assert d.certified


def _scenario(data, n, veh):
    t = np.arange(n) * DT
    v0 = data.draw(st.floats(5.0, 40.0), label="v0")
    v1 = data.draw(st.floats(5.0, 40.0), label="v1")
    # the ramp stays inside [5, 40] m/s (np.clip: the last sample can round below v1 = 5)
    vx = np.clip(v0 + (v1 - v0) * t / t[-1], 5.0, 40.0)
    amp = data.draw(st.floats(0.0, 0.06), label="steer amplitude")
    f = data.draw(st.floats(0.05, 2.0), label="steer frequency")
    step = data.draw(st.booleans(), label="steps")
    s = np.sin(2 * np.pi * f * t)
    u = amp * (np.sign(s) if step else s)
    seed = data.draw(st.integers(0, 2**31 - 1), label="seed")
    corners = data.draw(st.booleans(), label="corners")
    xi = ub.random_stiffness_trajectory(veh, n, DT, seed=seed, corr_time=0.3, corners=corners)
    return vx, u, xi


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_enclosure_guarantee_property(bmw_design, data):
    """x^- <= x <= x^+ at every sample for the LPV model (Euler, T_s = 10 ms) of a car the
    original observer refuses, any stiffness trajectory in the box, bounded steering and gyro
    noise, any x0 in the initial box (tolerance: rounding only)."""
    n = 1500
    vx, u, xi = _scenario(data, n, BMW)
    c = np.array([data.draw(st.floats(-1.0, 1.0)), data.draw(st.floats(-0.5, 0.5))])
    hw = np.array([data.draw(st.floats(0.0, 1.0)), data.draw(st.floats(0.0, 0.5))])
    fr = np.array([data.draw(st.floats(0, 1)), data.draw(st.floats(0, 1))])
    x0 = c - hw + 2 * hw * fr
    un = data.draw(st.floats(0.0, 0.01), label="steering bound")
    vbar = data.draw(st.floats(0.0, 0.01), label="gyro bound")
    k = np.arange(n)
    X = ub.simulate_lpv(BMW, x0, u, vx, xi, DT)
    um = u + un * np.sin(k * 0.37)
    y = X[:, 1] + vbar * np.cos(k * 0.91)
    res = ic.run(bmw_design, DT, vx, um - un, um + un, y, c - hw, c + hw, y_noise=vbar)
    tol = 1e-9 * (1 + np.abs(X))
    assert np.all(res.x_lo <= X + tol), "lower bound above the state"
    assert np.all(X <= res.x_hi + tol), "upper bound below the state"


def test_bounds_converge_on_exact_model(bmw_design):
    """Not only enclosure: with the true stiffness at the box centre the width of v_y settles
    well below the initial 2 m/s (the observer is not trivially wide)."""
    t = np.arange(0, 20, DT)
    vx = np.full_like(t, 20.0)
    u = 0.03 * np.sin(2 * np.pi * 0.3 * t)
    X = ub.simulate_lpv(BMW, [0.0, 0.0], u, vx, BMW.xi0, DT)
    res = ic.run(bmw_design, DT, vx, u, u, X[:, 1], [-1.0, -0.2], [1.0, 0.2])
    late = t > 10
    assert res.width[late, 0].max() < 0.5 * 2.0
    assert np.all(res.x_lo <= X + 1e-9) and np.all(X <= res.x_hi + 1e-9)


def _drive(n=1500):
    t = np.arange(n) * DT
    vx = 6.0 + 30.0 * t / t[-1]                       # crosses the three bands
    u = 0.03 * np.sin(2 * np.pi * 0.3 * t)
    xi = ub.random_stiffness_trajectory(BMW, n, DT, seed=4, corr_time=0.3)
    X = ub.simulate_lpv(BMW, [0.2, 0.0], u, vx, xi, DT)
    return t, np.column_stack([vx, u]), X


def test_observer_protocol_readable_step_equals_compiled_run(bmw_design):
    """The contract: run_readable (numpy Euler step of (11) in z, the x box mapped to z under
    T and the z box back under T^-1) equals the compiled run. Tolerance 1e-10 absolute on
    bounds of order 0.1-1 (observed ~1e-15): the same arithmetic summed in a different order
    per step, on stable width dynamics."""
    t, u, X = _drive()
    obs = ic.CoordinateIntervalObserver(bmw_design, DT, ([-1.0, -0.2], [1.0, 0.2]),
                                        steer_noise=1e-3, y_noise=1e-3)
    assert isinstance(obs, Observer)
    run = obs.run(t, u, X[:, 1])
    ref = run_readable(obs, t, u, X[:, 1])
    np.testing.assert_allclose(run.lo, ref.lo, rtol=0, atol=1e-10)
    np.testing.assert_allclose(run.hi, ref.hi, rtol=0, atol=1e-10)
    assert np.all(run.lo <= X + 1e-9) and np.all(X <= run.hi + 1e-9)
    assert obs.design.certificate is bmw_design.design.solution.certificate
    # the function front end: same numbers
    f = ic.run(bmw_design, DT, u[:, 0], u[:, 1] - 1e-3, u[:, 1] + 1e-3, X[:, 1],
               [-1.0, X[0, 1] - 0.2], [1.0, X[0, 1] + 0.2], y_noise=1e-3)
    np.testing.assert_array_equal(f.lo, run.lo)
    np.testing.assert_array_equal(f.hi, run.hi)


def test_observer_is_causal(bmw_design):
    t, u, X = _drive()
    obs = ic.CoordinateIntervalObserver(bmw_design, DT, ([-1.0, -0.2], [1.0, 0.2]))
    a = obs.run(t, u, X[:, 1])
    k = 700
    u2, y2 = u.copy(), X[:, 1].copy()
    u2[k + 1:, 1] *= 1.3
    u2[k + 1:, 0] -= 1.0
    y2[k + 1:] += 0.02
    b = obs.run(t, u2, y2)
    np.testing.assert_array_equal(a.lo[:k + 1], b.lo[:k + 1])
    np.testing.assert_array_equal(a.hi[:k + 1], b.hi[:k + 1])
    assert np.abs(a.hi[k + 2:] - b.hi[k + 2:]).max() > 1e-4


def test_arguments_are_checked(bmw_design):
    for dt in (0.0, -0.01, float("nan")):
        with pytest.raises(ObserverArgumentError, match="dt must be finite and > 0"):
            ic.design(BMW, BANDS, dt, kappas=(-0.1,))
        with pytest.raises(ObserverArgumentError, match="dt .sample period. must be finite"):
            ic.CoordinateIntervalObserver(bmw_design, dt, ([0, 0], [1, 1]))
    with pytest.raises(ObserverArgumentError, match="must be a CoordinateIntervalDesign"):
        ic.CoordinateIntervalObserver(bmw_design.design, DT, ([0, 0], [1, 1]))
    with pytest.raises(ObserverArgumentError, match="x0_lo <= x0_hi"):
        ic.run(bmw_design, DT, np.full(5, 10.0), np.zeros(5), np.zeros(5), np.zeros(5),
               [1.0, 0.0], [0.0, 1.0])
