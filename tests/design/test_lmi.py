import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, InfeasibleDesign
from vehicle_observers.design.lmi import LMIDesign, Region, check_matrix, disk, halfplane, sector

# eigenvalues -1 +- 5j: real part -1, modulus sqrt(26) = 5.10, damping 1/sqrt(26) = 0.196
A_OSC = np.array([[0.0, 1.0], [-26.0, -2.0]])


def lyapunov_design(A, regions=()):
    n = A.shape[0]
    d = LMIDesign("lyapunov")
    d.symmetric("P", n)
    d.positive("P>0", lambda V: V.P)
    d.negative("A'P+PA<0", lambda V: A.T @ V.P + V.P @ A)
    for k, reg in enumerate(regions):
        d.negative(f"region{k}", lambda V, reg=reg: reg.lmi(V.P, V.P @ A))
    return d


def test_lyapunov_feasible_and_certified():
    sol = lyapunov_design(A_OSC).solve()
    assert sol.certificate.ok
    P = sol["P"]
    # independent check: the Lyapunov matrix is negative definite
    assert np.linalg.eigvalsh(A_OSC.T @ P + P @ A_OSC).max() < 0
    assert np.linalg.eigvalsh(P).min() > 0
    assert sol.certificate.min_margin > 0
    assert "A'P+PA<0" in sol.summary()


def test_unstable_is_infeasible_with_clear_error():
    A = np.array([[0.1, 1.0], [0.0, -1.0]])
    with pytest.raises(InfeasibleDesign, match="infeasible"):
        lyapunov_design(A).solve()


def test_certificate_rejects_bad_values_and_names_constraint():
    d = lyapunov_design(A_OSC)
    cert = d.certify({"P": -np.eye(2)})
    assert not cert.ok
    assert cert.worst().name in ("P>0", "A'P+PA<0")
    # a feasible-looking solver output that fails the check raises CertificationError
    d2 = lyapunov_design(A_OSC)
    d2.negative("impossible", lambda V: np.eye(2))  # constant, checked only by the certificate
    with pytest.raises(CertificationError, match="'impossible'.*largest eigenvalue = 1.000e\\+00"):
        d2.solve()


@pytest.mark.parametrize("region, feasible", [
    (halfplane(0.5), True), (halfplane(1.5), False),
    (disk(6.0), True), (disk(4.0), False),
    (sector(np.radians(80)), True), (sector(np.radians(75)), False),
])
def test_regions_known_answer(region, feasible):
    eig = np.linalg.eigvals(A_OSC)
    assert region.contains(eig).all() == feasible
    d = lyapunov_design(A_OSC, [region])
    if feasible:
        assert d.solve().certificate.ok
    else:
        with pytest.raises(InfeasibleDesign):
            d.solve()


def test_region_contains_geometry():
    z = np.array([-2 + 0j, -0.5 + 0j, -3 + 3j, 7 + 0j])
    np.testing.assert_array_equal(halfplane(1.0).contains(z), [True, False, True, False])
    np.testing.assert_array_equal(disk(3.5).contains(z), [True, True, False, False])
    np.testing.assert_array_equal(sector(np.radians(50)).contains(z), [True, True, True, False])


def test_check_matrix_kinds():
    assert check_matrix("n", -np.eye(3), "neg").margin == pytest.approx(1.0)
    assert check_matrix("p", np.diag([2.0, 3.0]), "pos").margin == pytest.approx(2.0)
    c = check_matrix("m", np.array([[1.0, -0.5], [0.0, 2.0]]), "nonneg")
    assert not c.ok and c.margin == pytest.approx(-0.5)
    assert not check_matrix("nan", np.array([[np.nan]]), "neg").ok


def test_diagonal_variable_and_objective():
    # min gamma s.t. diag P > 0, A'P + PA + I < gamma-like bound: check diagonal structure kept
    A = np.array([[-2.0, 0.5], [0.3, -1.0]])
    d = LMIDesign("diag")
    d.diagonal("P", 2)
    d.scalar("g")
    d.positive("P>0", lambda V: V.P)
    d.negative("lyap", lambda V: A.T @ V.P + V.P @ A)
    d.negative("P<gI", lambda V: V.P - V.g * np.eye(2))
    d.extra(lambda V: [V.P[0, 0] >= 1])
    sol = d.solve(objective=lambda V: V.g)
    P = sol["P"]
    assert P[0, 1] == 0 and P[1, 0] == 0
    assert sol.objective == pytest.approx(max(P[0, 0], P[1, 1]), rel=1e-4)


def test_nonnegative_with_margin_is_certified():
    # Metzler-type constraint: off-diagonal of A - L C >= 0 with a solver margin
    A = np.array([[-1.0, -0.5], [0.3, -2.0]])
    C = np.array([[0.0, 1.0]])
    d = LMIDesign("metzler")
    d.matrix("L", (2, 1))
    d.nonnegative("offdiag", lambda V: (A - V.L @ C)[0:1, 1:2], margin=1e-3)
    sol = d.solve(objective=lambda V: V.L[0, 0] ** 2 + V.L[1, 0] ** 2)
    assert (A - sol["L"] @ C)[0, 1] == pytest.approx(1e-3, abs=1e-7)
    assert sol.certificate.ok


# ---- bad arguments from a notebook: the package's errors, naming the argument --------------
def _design(builder, kind="negative", **fixed):
    d = LMIDesign("nb")
    d.symmetric("P", 2)
    for k, v in fixed.items():
        d.fixed(k, v)
    d.positive("P>0", lambda V: V.P)
    getattr(d, kind)("c", builder)
    return d


@pytest.mark.parametrize("make, match", [
    (lambda: _design(lambda V: V.P @ V.B, B=np.ones((2, 3))), "constraint 'c' is a 2 x 3 matrix"),
    (lambda: _design(lambda V: V.B.T @ V.P, B=np.ones((2, 3))), "constraint 'c' is a 3 x 2"),
    (lambda: _design(lambda V: V.P + V.B, B=np.ones((3, 3))), "constraint 'c' cannot be built"),
    (lambda: _design(lambda V: V.X), "reads variable 'X', which is not defined"),
])
def test_non_square_or_mismatched_lmi_names_the_constraint(make, match):
    from vehicle_observers.core.errors import ObserverArgumentError

    d = make()
    with pytest.raises(ObserverArgumentError, match=match):
        d.solve()
    with pytest.raises(ObserverArgumentError, match=match):
        d.certify({"P": np.eye(2), "B": d._vars.get("B", 0)})


def test_non_square_matrix_variable_in_an_lmi_names_the_constraint():
    from vehicle_observers.core.errors import ObserverArgumentError

    d = LMIDesign("nb")
    d.matrix("K", (2, 3))
    d.negative("K<0", lambda V: V.K)
    with pytest.raises(ObserverArgumentError, match="'K<0' is a 2 x 3 matrix"):
        d.solve()


@pytest.mark.parametrize("call, match", [
    (lambda d: d.symmetric("P", 0), "symmetric variable 'P': n must be a positive integer"),
    (lambda d: d.symmetric("P", 2.5), "n must be a positive integer, got 2.5"),
    (lambda d: d.diagonal("D", -1), "diagonal variable 'D'"),
    (lambda d: d.matrix("K", (2, 0)), "matrix variable 'K': shape entry"),
    (lambda d: d.matrix("K", 3), "shape must be \\(rows, columns\\)"),
    (lambda d: d.fixed("A", np.zeros((0, 2))), "constant 'A' has shape \\(0, 2\\)"),
    (lambda d: d.fixed("A", "abc"), "constant 'A' must be numeric"),
    (lambda d: d.nonnegative("m", lambda V: V, margin=-1.0), "margin must be"),
    (lambda d: d.negative("c", np.eye(2)), "builder must be a function"),
])
def test_bad_variable_arguments_name_the_argument(call, match):
    from vehicle_observers.core.errors import ObserverArgumentError

    with pytest.raises(ObserverArgumentError, match=match):
        call(LMIDesign("nb"))


@pytest.mark.parametrize("call, match", [
    (lambda: disk(0.0), "disk: R \\(radius\\) must be a finite number > 0, got 0.0"),
    (lambda: disk(np.inf), "disk: R"),
    (lambda: halfplane(np.nan), "halfplane: a must be a finite number"),
    (lambda: sector(0.0), "sector: theta must be in \\(0, pi/2\\)"),
    (lambda: Region("r", np.zeros((2, 2)), np.zeros((2, 3))), "M must be a finite square"),
    (lambda: Region("r", np.eye(1), np.eye(2)), "must have the same shape"),
    (lambda: disk(1.0).contains([np.nan]), "z must be finite"),
    (lambda: LMIDesign("nb", eps=-1.0), "eps must be a finite number >= 0"),
    (lambda: check_matrix("c", np.ones((2, 3)), "neg"), "'c' is a 2 x 3 matrix"),
    (lambda: check_matrix("c", np.zeros((0, 0)), "pos"), "non-empty"),
    (lambda: check_matrix("c", np.eye(2), "negative"), "kind must be"),
])
def test_bad_region_and_check_arguments_name_the_argument(call, match):
    from vehicle_observers.core.errors import ObserverArgumentError

    with pytest.raises(ObserverArgumentError, match=match):
        call()


def test_certificate_of_huge_entries_fails_cleanly_not_in_lapack():
    """Entries near the float limit: (M + M^T)/2 would overflow to inf and LAPACK raise a
    bare LinAlgError; the check reports a failed constraint instead."""
    M = np.full((2, 2), 1.7e308)
    c = check_matrix("big", M, "pos")
    assert np.isfinite(c.margin) and c.margin < 0 or not c.ok
    assert check_matrix("zero", np.zeros((2, 2)), "neg").margin == 0.0   # zero scale: 0, not NaN
