import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError, PremiseOutOfBounds
from vehicle_observers.models import bicycle, lateral
from vehicle_observers.models.ts import (
    Premise,
    SectorTS,
    jacobian_ts_from_bounds,
    jacobian_ts_from_samples,
    memberships,
    numerical_jacobian,
    vertex_bits,
)
from vehicle_observers_papers.ichalal_2011 import constants as I
from vehicle_observers_papers.yacine_2015 import constants as Y


def test_memberships_convex_and_vertex_order():
    zmin, zmax = np.array([0.0, -1.0, 2.0]), np.array([1.0, 1.0, 5.0])
    rng = np.random.default_rng(0)
    z = zmin + rng.random((500, 3)) * (zmax - zmin)
    h = memberships(z, zmin, zmax)
    assert h.shape == (500, 8)
    assert np.all(h >= 0) and np.abs(h.sum(axis=1) - 1).max() < 1e-15
    # at each vertex exactly one rule is active: bit 0 -> zmax, first premise most significant
    bits = vertex_bits(3)
    for i, b in enumerate(bits):
        zv = np.where(b == 0, zmax, zmin)
        np.testing.assert_allclose(memberships(zv, zmin, zmax), np.eye(8)[i], atol=1e-15)


def _toy_ts():
    # x' = [[-1, z1], [z1*z2, -z2]] x + [z2, 1]^T u : multi-affine
    prem = [Premise("z1", -1.0, 2.0), Premise("z2", 0.5, 3.0)]
    mats = lambda z: (np.array([[-1.0, z[0]], [z[0] * z[1], -z[1]]]),
                      np.array([[z[1]], [1.0]]))
    fn = lambda x, u: np.column_stack([np.sin(x[:, 0]) + 0.5, 1.75 + 1.2 * np.cos(x[:, 1])])
    return SectorTS(prem, mats, premise_fn=fn, name="toy"), mats, fn


def test_exact_on_multiaffine_model():
    ts, mats, fn = _toy_ts()
    rng = np.random.default_rng(1)
    x = rng.normal(size=(300, 2))
    u = rng.normal(size=(300, 1))

    def f_nl(x, u):
        z = fn(x, u)
        out = np.empty_like(x)
        for k in range(len(x)):
            A, B = mats(z[k])
            out[k] = A @ x[k] + B @ u[k]
        return out

    res = ts.exactness(x, u, f_nl)
    assert res["max_rel_diff"] < 1e-13
    assert res["convex_sum_residual"] < 1e-15


def test_rejects_non_multiaffine():
    prem = [Premise("z", 0.0, 1.0)]
    with pytest.raises(ValueError, match="not multi-affine"):
        SectorTS(prem, lambda z: (np.array([[z[0] ** 2]]), np.zeros((1, 1))))


def test_out_of_bounds_message_names_premise_and_sample():
    ts, _, _ = _toy_ts()
    z = np.array([[0.0, 1.0], [0.5, 1.0], [2.5, 1.0], [3.0, 1.0]])
    with pytest.raises(PremiseOutOfBounds) as ei:
        ts.memberships(z)
    e = ei.value
    assert e.premise == "z1" and e.index == 2 and e.value == 2.5 and e.bounds == (-1.0, 2.0)
    assert "sample 2" in str(e) and "'z1'" in str(e) and "2 of 4 samples" in str(e)
    # clipping saturates instead
    h = ts.memberships(z, clip=True)
    np.testing.assert_allclose(h.sum(axis=1), 1.0)


def test_premise_requires_ordered_bounds():
    with pytest.raises(ValueError, match="zmax > zmin"):
        Premise("bad", 1.0, 1.0)


def test_yacine_ts_exact_inside_sector_random_states():
    p, ts = Y.params, Y.ts_model()
    rng = np.random.default_rng(2)
    n = 4000
    x = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-0.6, 0.6, n),
                         rng.uniform(-8, 8, n), rng.uniform(-8, 8, n)])
    vx = rng.uniform(Y.vx_min, Y.vx_max, n)
    u = rng.uniform(-0.1, 0.1, n)
    af, ar = lateral.slip_angles(x[:, 0], x[:, 1], u, vx, p, exact=False)
    k = (np.abs(af) <= Y.alpha_slip_max) & (np.abs(ar) <= Y.alpha_slip_max)
    assert k.sum() > 200
    res = ts.exactness(x[k], u[k], lambda x_, u_, v_: lateral.rhs_transformed(x_, np.ravel(u_), v_, p),
                       vx[k])
    assert res["max_rel_diff"] < 1e-12
    assert ts.n_rules == 8
    # vertex 0 is (f_r max, f_f max, v_x max): the paper's A_1 of (21) at v_x max
    A0 = ts.A[0]
    assert A0[2, 0] == pytest.approx(-(Y.M_f1 + Y.M_r1) / (Y.m * Y.r_relax))
    assert A0[0, 1] == pytest.approx(-Y.vx_max)
    assert ts.B[0][2, 0] == pytest.approx(Y.vx_max * Y.M_f1 / (Y.m * Y.r_relax))


def test_bicycle_ts_exact():
    bp = I.params
    rng = np.random.default_rng(3)
    x = np.column_stack([rng.normal(size=500), rng.uniform(-0.1, 0.1, 500),
                         rng.uniform(-1.0, 1.0, 500), rng.normal(size=500)])
    u = rng.normal(size=500)
    z = bicycle.ts_premises(x, u, bp)
    ts = bicycle.bicycle_ts(bp, list(zip(z.min(axis=0) - 1e-9, z.max(axis=0) + 1e-9)))
    res = ts.exactness(x, u, lambda x_, u_: bicycle.rhs(x_, np.ravel(u_), bp))
    assert res["max_rel_diff"] < 1e-13


# ---- Jacobian TS model (Ichalal 2011, (14)-(18), (34)) ---------------------------------
def test_numerical_jacobian_of_linear_map_is_exact():
    A = np.array([[1.0, 2.0], [-3.0, 0.5]])
    x = np.random.default_rng(1).normal(size=(4, 2))
    J = numerical_jacobian(lambda x, u: x @ A.T, x, None)
    np.testing.assert_allclose(J, np.broadcast_to(A, (4, 2, 2)), rtol=0, atol=1e-9)


def _bike_jts():
    bp = I.params
    t = np.arange(0, 10, 2e-3)
    X, U = bicycle.simulate(bp, t)
    return jacobian_ts_from_samples(bicycle.jacobian(X, U, bp), names=["xi1", "xi2"]), X, U


def test_jacobian_ts_detects_varying_entries_and_interpolates_exactly():
    jts, X, U = _bike_jts()
    assert jts.entries == [(3, 1), (3, 2)]
    assert jts.q == 4
    J = bicycle.jacobian(X, U, I.params)
    h = jts.weights(J)
    np.testing.assert_allclose(h.sum(axis=1), 1.0, atol=1e-12)
    assert h.min() >= -1e-12
    np.testing.assert_allclose(np.einsum("ni,ijk->njk", h, jts.vertices), J, atol=1e-9)


def test_jacobian_ts_vertex_ordering_matches_printed_34():
    jts = jacobian_ts_from_bounds(
        np.array([[0, 30.0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]]),
        {(3, 1): I.xi1_bounds_printed, (3, 2): I.xi2_bounds_printed})
    np.testing.assert_array_equal(jts.vertices, np.array(I.printed_jacobian_vertices()))
    # h1 = F1^1 F2^1: weight 1 on A1 when xi1, xi2 sit at their lower bounds
    J = jts.vertices[0][None]
    np.testing.assert_allclose(jts.weights(J), [[1, 0, 0, 0]], atol=1e-12)


def test_jacobian_ts_errors_name_the_entry():
    jts, _, _ = _bike_jts()
    J = jts.vertices[3].copy()
    J[3, 2] += 1.0
    with pytest.raises(PremiseOutOfBounds, match="xi2"):
        jts.weights(J[None])
    np.testing.assert_allclose(jts.weights(J[None], clip=True), [[0, 0, 0, 1]], atol=1e-12)
    with pytest.raises(ObserverArgumentError, match="upper > lower"):
        jacobian_ts_from_bounds(np.zeros((2, 2)), {(0, 1): (2.0, 1.0)})
    with pytest.raises(ObserverArgumentError, match="outside a 2x2"):
        jacobian_ts_from_bounds(np.zeros((2, 2)), {(2, 1): (0.0, 1.0)})
    with pytest.raises(ObserverArgumentError, match="shape"):
        jacobian_ts_from_samples(np.zeros((3, 2, 3)))
    bad = np.zeros((3, 2, 2))
    bad[1, 0, 0] = np.nan
    with pytest.raises(ObserverArgumentError, match="sample 1"):
        jacobian_ts_from_samples(bad)
