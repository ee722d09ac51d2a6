"""Published problems with printed numerical answers, reproduced by ``vehicle_observers.design``.

Each test names its source (authors, year, title, venue, example), the place the printed
numbers were read (a repository path or a documentation URL) with the numbers quoted, what the
layer computes, the tolerance and why, and solves the problem a second time with an
independent cvxpy (or numpy/scipy) formulation written here. Where the printed answer is a
gain that is one of many solutions, the test checks what is unique or what the paper claims
about it: the printed identities, that the printed gain satisfies the design's constraints
(certified by the layer's data certificate), its error poles, and that the layer's own design
on the same data is feasible at least as far as the printed one.

Printed numbers are quoted with 4 decimals in every source used here; "half a unit of the
last printed digit" (5e-5) is the rounding of one printed entry, and a sum of ``k`` rounded
entries can be off by ``k * 5e-5``.

| problem | printed | computed by the layer |
|---|---|---|
| Wang 2018 Ex. 1, interval obs. | T, N, L | T + N C = I, T A - L C >= 0, rho 0.1040 |
| Wang 2018 Ex. 2, interval obs. | T, N, L | idem, rho 0.4196 |
| Chen & Patton 1999 p. 76 UIO | H, T, T A, K1, F, K | equal to 1e-4; poles of F |
| Nazari 2015 quarter-car UIO | H, T, T A, k1, k | equal (1e3 x 5e-5) |
| MATLAB ``feasp`` example | t_min = -3.1363 | quadratic stability certified |
| MATLAB ``hinfnorm`` example | ninf = 3.0150 | 3.014975 |
| Gahinet, LMI Toolbox ``sateldem`` | H-inf optimum with poles in region "near 0" | 3.5e-5 |
| Chen, Patton & Zhang 1996 jet engine UIO | H, T, K, poles -3 | H to 5e-5, T 1.4e-4, K 3.7e-3 |
| Efimov et al. 2013 ECC, S^-1 x | no cooperative L; L; R, S | infeasible; exact; R != S^-1 D S |
"""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.certify import certify_observer, hinf_norm
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion, Metzler
from vehicle_observers.design.lmi import halfplane, sector, unit_disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.design.uio import uio_system

PRINTED = 5e-5          # half a unit of the 4th printed decimal


# ---- independent formulations (cvxpy / numpy), written here, not taken from the layer -------
def _diagonal_schur_certificate(G, floor=2.0):
    """A diagonal ``P >= floor I`` with ``[[-P, P G], [G^T P, -P]] < 0`` (Schur), by cvxpy:
    for a nonnegative ``G`` one exists iff ``rho(G) < 1`` (positive systems). ``floor`` 2
    keeps ``P - I`` (the layer's default normalisation) away from zero."""
    n = G.shape[0]
    p = cp.Variable(n)
    P = cp.diag(p)
    M = cp.bmat([[-P, P @ G], [G.T @ P, -P]])
    prob = cp.Problem(cp.Minimize(0), [p >= floor, (M + M.T) / 2 << -1e-6 * np.eye(2 * n)])
    prob.solve(solver="CLARABEL")
    assert prob.status == cp.OPTIMAL, prob.status
    return np.diag(p.value)


def _cvxpy_positive_schur_design(At, C, rho):
    """Independent synthesis: diagonal ``P``, ``K = P L``, ``P At - K C`` entry-wise >= 0 and
    ``[[-rho P, P At - K C], [*, -rho P]] < 0`` (poles in ``|z| < rho``). True if feasible."""
    n, p = At.shape[0], C.shape[0]
    d = cp.Variable(n)
    P = cp.diag(d)
    K = cp.Variable((n, p))
    X = P @ At - K @ C
    M = cp.bmat([[-rho * P, X], [X.T, -rho * P]])
    prob = cp.Problem(cp.Minimize(0), [d >= 1.0, X >= 0, (M + M.T) / 2 << -1e-7 * np.eye(2 * n)])
    prob.solve(solver="CLARABEL")
    return prob.status == cp.OPTIMAL


def _interval_observer_case(A, C, T, N, L):
    """Checks shared by Wang (2018) Examples 1 and 2 (their docstrings say what is printed).

    The observer (Wang 2018 eq. (8)) is ``zeta+ = T A xhat + L (y - C xhat) + Delta``,
    ``xhat = zeta + N y``; its error obeys ``e+ = (T A - L C) e + (bounded terms)``, so the
    interval is valid and bounded iff ``G = T A - L C`` is entry-wise nonnegative (a positive
    discrete-time system) and Schur; ``T + N C = I`` makes the estimate consistent."""
    n = A.shape[0]
    # printed identity T + N C = I: each entry is a sum of at most 2 printed numbers
    assert np.abs(T + N @ C - np.eye(n)).max() <= 2 * PRINTED
    At = T @ A
    G = At - L @ C
    assert G.min() >= 0.0                                  # the paper's positivity claim
    rho = float(np.abs(np.linalg.eigvals(G)).max())
    assert rho < 1.0                                       # ... and its stability claim
    # the layer's data certificate of the printed gain: unit disk + cooperativity, with a
    # diagonal P found independently (cvxpy); diag_shift 1e-12 asks diag(G) >= -1e-12
    system = PolytopicSystem(At, C, time="discrete", name="Wang 2018 (T A, C)")
    constraints = [InRegion(unit_disk(1.0)), Metzler(diag_shift=1e-12)]
    syn = ObserverSynthesis(system, constraints, P="diagonal")
    cert = certify_observer(syn, _diagonal_schur_certificate(G), L[None])
    assert cert.status == "certified", cert.reason()
    # the same certificate rejects a gain that breaks positivity (sign of L flipped: a
    # negative diagonal entry of T A + L C, which discrete-time positivity forbids)
    bad = certify_observer(syn, 2.0 * np.eye(n), -L[None])
    assert bad.status == "violated"
    assert bad.lmi.worst().name.startswith("metzler diag"), bad.reason()
    # the layer's own design on the printed T: cooperative and at least as fast as printed
    target = 1.05 * rho
    des = ObserverSynthesis(system, [InRegion(unit_disk(target)), Metzler(diag_shift=1e-9)],
                            P="diagonal").solve()
    assert des.status == "certified"
    Gl = At - des.L[0] @ C
    assert Gl.min() >= -1e-9 and np.abs(np.linalg.eigvals(Gl)).max() < target
    assert _cvxpy_positive_schur_design(At, C, target)     # independent formulation agrees
    return rho


def test_wang2018_example1_printed_interval_observer_is_positive_schur_and_reproduced():
    """Z. Wang (2018), "Interval observer design for uncertain discrete-time linear systems",
    Systems & Control Letters, Example 1: A = [[0.3, -0.7], [0.6, -0.5]], B = I, C = [1, 0].

    Printed numbers, read in W. Ren's reproduction of the paper, repository
    WJ-Ren/Program-for-existing-papers, file ``Example1.m`` (commit e446252), comment "Or one
    can use data from the paper as follows: T = [-0.0238, 0; -0.7294, 1]; N = [1.0238;
    0.7294]; L = [-0.0970; 0.3022];" (the numbers are the script's quotation of the
    paper, whose own page is not quoted here). They are a solution of the paper's LMI with a fixed H-infinity
    level, one of many, so the test checks what the paper claims of them, not their digits:
    T + N C = I (to 2 x 5e-5, printed rounding), T A - L C >= 0 and Schur (computed: spectral
    radius 0.1040), certified by the layer's data certificate; and the layer's own
    cooperative design on the printed T reaches a spectral radius <= 1.05 x the printed one
    (5 %: margin for the solver's strictness, not a fitted number), as does an independent
    cvxpy formulation.

    Catches: a positivity certificate that checks only the off-diagonal entries (the
    continuous-time Metzler property) and forgets the diagonal that discrete-time positivity
    needs (the flipped gain -L gives the entry -0.104 and must be 'violated' by that check),
    a discrete-time region LMI with the wrong block structure (a printed, valid gain would
    fail), a design layer that cannot reach a published design's speed under the same
    structure."""
    A = np.array([[0.3, -0.7], [0.6, -0.5]])
    C = np.array([[1.0, 0.0]])
    T = np.array([[-0.0238, 0.0], [-0.7294, 1.0]])
    N = np.array([[1.0238], [0.7294]])
    L = np.array([[-0.0970], [0.3022]])
    rho = _interval_observer_case(A, C, T, N, L)
    assert rho == pytest.approx(0.10395, abs=1e-4)


def test_wang2018_example2_printed_interval_observer_is_positive_schur_and_reproduced():
    """Z. Wang (2018), "Interval observer design for uncertain discrete-time linear systems",
    Systems & Control Letters, Example 2 (5 states, 2 outputs, C = [e1; e4]).

    Printed numbers, read in WJ-Ren/Program-for-existing-papers, file "Interval observer
    design for uncertain discrete-time linear systems/Example2.m" (commit e661433), comment
    "Or one can use data from the paper as follows: T = [ 0.2690 0 0 -0.1062 0; -0.3737 1 0
    -0.0683 0; -0.5762 0 1 0.2108 0; 0.1032 0 0 -0.0313 0; 0.7532 0 0 -1.0255 1]; N = [0.7310
    0.1062; 0.3737 0.0683; 0.5762 -0.2108; -0.1032 1.0313; -0.7532 1.0255]; L = [-0.2291
    -0.0974; 0.7722 0.3010; 0.2740 0.0900; -0.1230 -0.0790; -0.4762 -0.0859];" with A as in the
    script (entries 0.25 sqrt(2) in rows 4-5). Same checks and tolerances as Example 1
    (computed spectral radius of T A - L C: 0.4196; smallest entry 0.0090 >= 0).

    Catches: the same mistakes as Example 1 on a 5-state, 2-output case (block sizes of the
    region LMI and of the Metzler entries with p > 1)."""
    s2 = np.sqrt(2.0)
    A = np.array([[-0.54, 0.45, 0.36, 0.0, 0.0],
                  [0.63, 0.45, 0.18, 0.36, 0.0],
                  [0.09, 0.45, 0.27, 0.09, 0.18],
                  [0.0, 0.0, 0.25, 0.25 * s2, -0.25 * s2],
                  [0.0, 0.0, 0.0, 0.25 * s2, -0.25 * s2]])
    C = np.array([[1.0, 0, 0, 0, 0], [0, 0, 0, 1.0, 0]])
    T = np.array([[0.2690, 0, 0, -0.1062, 0],
                  [-0.3737, 1, 0, -0.0683, 0],
                  [-0.5762, 0, 1, 0.2108, 0],
                  [0.1032, 0, 0, -0.0313, 0],
                  [0.7532, 0, 0, -1.0255, 1]])
    N = np.array([[0.7310, 0.1062], [0.3737, 0.0683], [0.5762, -0.2108],
                  [-0.1032, 1.0313], [-0.7532, 1.0255]])
    L = np.array([[-0.2291, -0.0974], [0.7722, 0.3010], [0.2740, 0.0900],
                  [-0.1230, -0.0790], [-0.4762, -0.0859]])
    rho = _interval_observer_case(A, C, T, N, L)
    assert rho == pytest.approx(0.41958, abs=1e-4)


def test_chen_patton_uio_example_printed_matrices_and_poles():
    """Unknown-input observer of J. Chen & R. J. Patton (1999), *Robust Model-Based Fault
    Diagnosis for Dynamic Systems*, Springer, the example of p. 76 (the UIO of Chen, Patton &
    Zhang): A = [[-1, 1, 0], [-1, 0, 0], [0, -1, -1]], C = [[1, 0, 0], [0, 0, 1]],
    E = [-1, 0, 0]^T.

    Printed numbers, read in S. Nazari (2015), "A review of the unknown input observer with
    examples" (memo, Northeastern University; its reference [1] is Chen & Patton 1999),
    Sec. 3.1 ("taken from page 76 of [1]"), repository
    snazari/Unknown-Input-Observer-Review-and-Examples, file ``UIONotes.pdf`` (MATLAB output,
    text extracted with pdfminer; the extraction scrambles the column layout, the matrices
    below are reassembled from it and satisfy the memo's own relations F = A1 - K1 C and
    K = K1 + F H to 1e-4): H = [1 0; 0 0; 0 0], T = diag(0, 1, 1), A1 = T A = [0 0 0; -1 0 0;
    0 -1 -1], "K1 = place(A',C',[-2,-10,-5])'" = [6.7231 -3.7816; 7.5581 -11.3458; -3.0543
    8.2769], F = [-6.7231 0 3.7816; -8.5581 0 11.3458; 3.0543 -1.0000 -9.2769], K = [0
    -3.7816; -1.0 -11.3458; 0 8.2769], and the text "place the observer poles at [-2, -10,
    -5]".

    The layer (``design.uio``): H C E = E leaves the second column of H free; the memo's
    "H = E*inv((C*E)'*(C*E))*(C*E)'" is the minimum-norm solution, the one the layer takes
    (H = E (C E)^+), so H, T, T A must equal the printed ones exactly; the observer
    matrices from the printed K1 (``Decoupling.gains``: N = T A - K1 C, L = K1 + N H) must equal
    the printed F and K to 2 x 5e-5 (one printed entry of K1 plus rounding of the printed F).
    The poles: ``place`` was called on (A, C), not on (T A, C), so the printed K1 puts
    eig(A - K1 C) at {-2, -5, -10} (checked to 1e-3, the effect of rounding K1), while the
    UIO's error matrix F = T A - K1 C has poles {-10.457, -4.638, -0.906}: stable, but not the
    stated ones. The layer's data certificate of the printed gain therefore certifies a decay
    rate 0.8 (P found by cvxpy) and calls decay 0.95 'violated', naming the pole. Independent
    check: numpy eigenvalues and a cvxpy decay-0.8 LMI.

    Catches: a decoupling that is not H C E = E or not minimum-norm (H, T would differ), the
    gain formula without the N H term (L = K1 would not give the printed K), a pole
    certificate computed on A - L C instead of the decoupled T A - L C (it would pass 0.95)."""
    A = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, -1.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    E = np.array([[-1.0], [0.0], [0.0]])
    H_pr = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    T_pr = np.diag([0.0, 1.0, 1.0])
    A1_pr = np.array([[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, -1.0]])
    K1 = np.array([[6.7231, -3.7816], [7.5581, -11.3458], [-3.0543, 8.2769]])
    F_pr = np.array([[-6.7231, 0.0, 3.7816], [-8.5581, 0.0, 11.3458], [3.0543, -1.0, -9.2769]])
    K_pr = np.array([[0.0, -3.7816], [-1.0, -11.3458], [0.0, 8.2769]])

    system, dec = uio_system(PolytopicSystem(A, C), E)
    np.testing.assert_allclose(dec.H, H_pr, atol=1e-12)
    np.testing.assert_allclose(dec.T, T_pr, atol=1e-12)
    np.testing.assert_allclose(system.A[0], A1_pr, atol=1e-12)
    assert dec.residual <= 1e-12
    Nm, Lm, _ = dec.gains(A, np.zeros((3, 1)), K1, C)
    np.testing.assert_allclose(Nm, F_pr, atol=2 * PRINTED)
    np.testing.assert_allclose(Lm, K_pr, atol=2 * PRINTED)
    # what the printed K1 really places: eig(A - K1 C), not the UIO error matrix
    placed = np.sort(np.linalg.eigvals(A - K1 @ C).real)
    np.testing.assert_allclose(placed, [-10.0, -5.0, -2.0], atol=1e-3)
    uio_poles = np.sort(np.linalg.eigvals(Nm).real)
    np.testing.assert_allclose(uio_poles, [-10.4565, -4.6379, -0.9055], atol=1e-3)
    # the layer's data certificate of the printed gain on the decoupled system
    n = 3
    Pv = cp.Variable((n, n), symmetric=True)
    M = F_pr.T @ Pv + Pv @ F_pr + 1.6 * Pv
    cp.Problem(cp.Minimize(0), [Pv >> 2 * np.eye(n), (M + M.T) / 2 << -1e-6 * np.eye(n)]).solve(
        solver="CLARABEL")
    ok = certify_observer(ObserverSynthesis(system, [Decay(0.8)]), Pv.value, K1[None])
    assert ok.status == "certified", ok.reason()
    too_fast = certify_observer(ObserverSynthesis(system, [Decay(0.95)]), Pv.value, K1[None])
    assert too_fast.status == "violated"
    assert any("-0.9055" in f for f in too_fast.pole_failures), too_fast.pole_failures
    # (C, T A) is observable (the memo: rank(obsv(A1, C)) = 3): no mode is out of reach
    assert system.unobservable_modes() == []


def test_quarter_car_uio_printed_decoupling_and_gains():
    """Quarter-car suspension UIO, S. Nazari (2015), "A review of the unknown input observer
    with examples", Sec. 3.2 (repository snazari/Unknown-Input-Observer-Review-and-Examples,
    ``UIONotes.pdf``): C = eye(4), E = [1; 1; 1; 1], mb = 300, mw = 60, bs = 1000,
    ks = 16000, kt = 190000, A = [0 1 0 0; [-ks -bs ks bs]/mb; 0 0 0 1; [ks bs -ks-kt -bs]/mw],
    observer matrix chosen F = diag(-4, -4, -4, -4), "k1 = inv(C)*(A-F-H*C*A)", "k = k1 + k2"
    with k2 = F H.

    Printed (MATLAB output; the text extraction lists each matrix column by column): "H ="
    sixteen entries 0.2500; T with four entries 0.7500 and twelve -0.2500 (compared as a
    multiset, the layout is lost); T A = "1.0e+03 *" [-0.0533 -0.1067 -0.0533 0.2133 | -0.0026
    -0.0069 -0.0036 0.0131 | 0.8450 0.8983 0.8450 -2.5883 | 0.0031 0.0064 0.0041 -0.0136];
    "k1 = 1.0e+03 *" [-0.0493 -0.1067 -0.0533 0.2133 | -0.0026 -0.0029 -0.0036 0.0131 | 0.8450
    0.8983 0.8490 -2.5883 | 0.0031 0.0064 0.0041 -0.0096]; "k = 1.0e+03 *" [-0.0503 -0.1077
    -0.0543 0.2123 | -0.0036 -0.0039 -0.0046 0.0121 | 0.8440 0.8973 0.8480 -2.5893 | 0.0021
    0.0054 0.0031 -0.0106] (columns separated by |).

    The layer: ``decoupling`` gives H = E (C E)^+ = ones(4, 4)/4 and T = I - H exactly;
    ``uio_system`` gives T A, and ``Decoupling.gains`` with K = k1 gives N = F and L = k, all
    equal to the printed values to 1e3 x 5e-5 = 0.05 (the printed rounding at the 1e3 scale).
    The data certificate of the printed gain (P = 2 I, written here: with C = I,
    He(P (T A - k1)) = -16 I) certifies a decay rate 3.9 and calls 4.1 'violated'
    (the poles are at -4). The layer's own design at decay 1 is certified (independent check:
    numpy eigenvalues of T A - L C).

    Catches: a decoupling normalised differently (H, T differ), a gain formula without the
    N H term (L would equal k1, not the printed k), a decay LMI with the factor 2 of 2 alpha P
    missing (its LMI would pass at 4.1: -16 + 2 x 4.1 < 0; only the pole check would object)."""
    mb, mw, bs, ks, kt = 300.0, 60.0, 1000.0, 16000.0, 190000.0
    A = np.array([[0.0, 1.0, 0.0, 0.0],
                  [-ks / mb, -bs / mb, ks / mb, bs / mb],
                  [0.0, 0.0, 0.0, 1.0],
                  [ks / mw, bs / mw, (-ks - kt) / mw, -bs / mw]])
    E = np.ones((4, 1))
    C = np.eye(4)

    def columns(v):                    # printed column by column, x 1e3
        return 1e3 * np.array(v).reshape(4, 4).T
    TA_pr = columns([-0.0533, -0.1067, -0.0533, 0.2133, -0.0026, -0.0069, -0.0036, 0.0131,
                     0.8450, 0.8983, 0.8450, -2.5883, 0.0031, 0.0064, 0.0041, -0.0136])
    k1_pr = columns([-0.0493, -0.1067, -0.0533, 0.2133, -0.0026, -0.0029, -0.0036, 0.0131,
                     0.8450, 0.8983, 0.8490, -2.5883, 0.0031, 0.0064, 0.0041, -0.0096])
    k_pr = columns([-0.0503, -0.1077, -0.0543, 0.2123, -0.0036, -0.0039, -0.0046, 0.0121,
                    0.8440, 0.8973, 0.8480, -2.5893, 0.0021, 0.0054, 0.0031, -0.0106])
    tol = 1e3 * PRINTED
    system, dec = uio_system(PolytopicSystem(A, C), E)
    np.testing.assert_allclose(dec.H, np.full((4, 4), 0.25), atol=1e-12)
    printed_T = np.array([0.75] * 4 + [-0.25] * 12)
    np.testing.assert_allclose(np.sort(dec.T.ravel()), np.sort(printed_T), atol=1e-12)
    np.testing.assert_allclose(system.A[0], TA_pr, atol=tol)
    F = -4.0 * np.eye(4)
    k1 = np.linalg.solve(C, A - F - dec.H @ C @ A)          # the memo's formula for k1
    np.testing.assert_allclose(k1, k1_pr, atol=tol)
    Nm, Lm, _ = dec.gains(A, np.zeros((4, 1)), k1, C)
    np.testing.assert_allclose(Nm, F, atol=1e-9)
    np.testing.assert_allclose(Lm, k_pr, atol=tol)
    P = 2.0 * np.eye(4)
    ok = certify_observer(ObserverSynthesis(system, [Decay(3.9)]), P, k1[None])
    assert ok.status == "certified", ok.reason()
    late = certify_observer(ObserverSynthesis(system, [Decay(4.1)]), P, k1[None])
    assert late.status == "violated"
    assert not late.lmi.ok and late.pole_failures          # both the LMI and the poles say so
    des = ObserverSynthesis(system, [Decay(1.0)]).solve()
    assert des.status == "certified"
    assert np.linalg.eigvals(system.A[0] - des.L[0] @ C).real.max() < -1.0


def test_matlab_feasp_example_quadratic_stability_of_three_vertices():
    """MATLAB Robust Control Toolbox documentation, ``feasp`` ("Compute solution to given
    system of LMIs"), example: find P > I with A_i^T P + P A_i < 0 for A1 = [-1 2; 1 -3],
    A2 = [-0.8 1.5; 1.3 -2.7], A3 = [-1.4 0.9; 0.7 -2.0] (quadratic stability of the polytope
    Co{A1, A2, A3}).

    Printed (https://kr.mathworks.com/help/robust/ref/feasp.html, example output):
    " Result:  best value of t:    -3.136305 / f-radius saturation:  0.000% of R =
    1.00e+09" and "The result tmin = -3.1363 means that the problem is f[easible]". The number
    t_min is where ``feasp``'s projective method stopped (its target is t < 0), not a unique
    optimum (t is unbounded below as P grows), so only its sign, the verdict "feasible", is a
    published answer: this check proves little beyond the layer agreeing with MATLAB on a
    3-vertex polytope.

    The layer: the vertex list with C = 0 (no output injection: the observer LMI
    ``He(P A_i - K C) + 2 alpha P < 0`` is then the plain Lyapunov LMI) and ``P - I > 0``, as in
    the example, is certified. Beyond the printed verdict: the layer's largest quadratic decay
    rate for this polytope (``maximise_decay``) equals, within the bisection tolerance 1e-3,
    an independent cvxpy bisection of ``A_i^T P + P A_i + 2 a P < 0`` (no printed value is
    quoted: the ``gevp`` page's example output was not available in the copies consulted), and
    it cannot exceed the slowest vertex, 0.061065 = -max Re eig(A2).

    Catches: a decay LMI with alpha P instead of 2 alpha P (the verdict would still agree,
    the decay rate would double: 0.122 against the bisection's 0.061), a bisection that
    stops on the infeasible side (the certificate of the optimum would fail)."""
    Av = [np.array([[-1.0, 2.0], [1.0, -3.0]]), np.array([[-0.8, 1.5], [1.3, -2.7]]),
          np.array([[-1.4, 0.9], [0.7, -2.0]])]
    system = PolytopicSystem(Av, np.zeros((1, 2)), name="feasp example")
    des = ObserverSynthesis(system, [Decay(0.0)], P_lower=1.0).solve()
    assert des.status == "certified"
    assert np.linalg.eigvalsh(des.P).min() > 1.0
    # independent feasibility problem exactly as printed (P > I, A_i^T P + P A_i < 0)
    P = cp.Variable((2, 2), symmetric=True)
    cons = [P >> np.eye(2) + 1e-6 * np.eye(2)] + [
        (A.T @ P + P @ A + (A.T @ P + P @ A).T) / 2 << -1e-6 * np.eye(2) for A in Av]
    prob = cp.Problem(cp.Minimize(0), cons)
    prob.solve(solver="CLARABEL")
    assert prob.status == cp.OPTIMAL
    # largest quadratic decay rate: layer vs independent bisection
    opt = ObserverSynthesis(system, [Decay(0.0)]).maximise_decay(hi=1.0, tol=1e-4)
    assert opt.status == "certified"

    def feasible(a):
        Q = cp.Variable((2, 2), symmetric=True)
        Ms = [A.T @ Q + Q @ A + 2 * a * Q for A in Av]
        c = [Q >> np.eye(2)] + [(M + M.T) / 2 << -1e-7 * np.eye(2) for M in Ms]
        pr = cp.Problem(cp.Minimize(0), c)
        pr.solve(solver="CLARABEL")
        return pr.status == cp.OPTIMAL
    lo, hi = 0.0, 1.0
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if feasible(mid) else (lo, mid)
    assert opt.optimum == pytest.approx(lo, abs=1e-3)
    slowest = -max(np.linalg.eigvals(A).real.max() for A in Av)
    assert opt.optimum <= slowest + 1e-4


def test_matlab_hinfnorm_example_printed_norm():
    """MATLAB Robust Control Toolbox documentation, ``hinfnorm`` ("H-infinity norm of dynamic
    system"), example "Norm of MIMO System": G(s) = [0, 3s/(s^2 + s + 10); (s + 1)/(s + 5),
    2/(s + 6)], ``[ninf, fpeak] = hinfnorm(G)``.

    Printed: "ninf = 3.0150", "fpeak = 3.1623" (three copies of the MathWorks page held in the
    Nemotron-CC-Math-v1 data set,
    https://huggingface.co/datasets/nvidia/Nemotron-CC-Math-v1, which agree).

    The layer computes the H-infinity norm of every error system in its certificate
    (``design.certify.hinf_norm``, Hamiltonian bisection, relative tolerance 1e-8); on a
    realisation of G (written here: controllable form of 3s/(s^2 + s + 10), (s + 1)/(s + 5) =
    1 - 4/(s + 5), 2/(s + 6); D = [[0, 0], [1, 0]]) it must give 3.0150 to 5e-5 (the printed
    rounding). Independent checks: the largest singular value of G(j w) at the printed peak
    frequency w = 3.1623 rad/s (= sqrt(10), the resonance of s^2 + s + 10) and the
    bounded-real lemma with a feedthrough, min gamma s.t. [[A^T P + P A, P B, C^T], [B^T P,
    -gamma I, D^T], [C, D, -gamma I]] < 0, P > 0, solved by cvxpy, both equal to 5e-5.

    This checks the norm the certificate uses to accept or reject an H-infinity design
    (it is not a synthesis: the layer's bounded-real constraint has no feedthrough from w to
    z, so it cannot pose this G).

    Catches: a Hamiltonian bisection that ignores D (it returns 3.01522, the norm of the
    strictly proper part: outside the tolerance), a bisection that stops early."""
    A = np.zeros((4, 4))
    A[0, 1], A[1, 0], A[1, 1], A[2, 2], A[3, 3] = 1.0, -10.0, -1.0, -5.0, -6.0
    B = np.zeros((4, 2))
    B[2, 0], B[1, 1], B[3, 1] = 1.0, 1.0, 1.0
    Cg = np.array([[0.0, 3.0, 0.0, 0.0], [0.0, 0.0, -4.0, 2.0]])
    D = np.array([[0.0, 0.0], [1.0, 0.0]])
    ninf = hinf_norm(A, B, Cg, D)
    assert ninf == pytest.approx(3.0150, abs=PRINTED)
    w = 3.1623
    Gjw = Cg @ np.linalg.solve(1j * w * np.eye(4) - A, B) + D
    assert np.linalg.svd(Gjw, compute_uv=False)[0] == pytest.approx(3.0150, abs=PRINTED)
    P = cp.Variable((4, 4), symmetric=True)
    g = cp.Variable()
    M = cp.bmat([[A.T @ P + P @ A, P @ B, Cg.T], [B.T @ P, -g * np.eye(2), D.T],
                 [Cg, D, -g * np.eye(2)]])
    cp.Problem(cp.Minimize(g), [P >> 0, (M + M.T) / 2 << 0]).solve(solver="CLARABEL")
    assert g.value == pytest.approx(3.0150, abs=PRINTED)
    assert g.value == pytest.approx(ninf, rel=1e-5)


def _satellite(k, f):
    """Two-body satellite of ``sateldem`` (module docstring of the test below): ``E0 x' =
    (a0 + k ak + f ad) x + b1 (w + T)``, returned as ``(A, B)`` with ``A = E0^-1 (...)``."""
    J1, J2 = 1.0, 0.1
    a0 = np.block([[np.zeros((2, 2)), np.eye(2)], [np.zeros((2, 4))]])
    e0 = np.diag([1.0, 1.0, J1, J2])
    ak = np.zeros((4, 4))
    ak[2:, :2] = [[-1.0, 1.0], [1.0, -1.0]]
    ad = np.zeros((4, 4))
    ad[2:, 2:] = [[-1.0, 1.0], [1.0, -1.0]]
    b1 = np.array([[0.0], [0.0], [1.0], [0.0]])
    return np.linalg.solve(e0, a0 + k * ak + f * ad), np.linalg.solve(e0, b1)


def test_gahinet_sateldem_hinf_state_feedback_with_pole_region_by_duality():
    """H-infinity state feedback with pole placement in an LMI region (Chilali & Gahinet,
    IEEE TAC 41(3), 1996, as implemented by ``msfsyn``): P. Gahinet, demo "SATELDEM: Robust
    state-feedback control of satellite attitude", LMI Control Toolbox, The MathWorks
    1995-2004 (Revision 1.13.2.3), file ``Matlab/toolbox/lmi/lmictrl/sateldem.m`` in the public
    repository HULCBio/MotionStation (commit 5ae2ec1); the example of the LMI Control Toolbox
    manual, p. 4-13.

    Data printed in the demo: J1 = 1, J2 = 0.1, "0.09 < k < 0.4 (nominal = 0.2450)",
    "0.0038 < f < 0.04 (nominal = 0.0188)", a0, ak, ad, e0 = diag([1 1 J1 J2]), b1 = b2 =
    [0;0;1;0], c1 = [0 1 0 0] (z = x2), d11 = d12 = 0; the region "alpha-stability -> half-plane
    x < -0.1" and "damping ... -> sector with tip at x=0 and angle 3*pi/4" (the demo plots its
    edges as x/tan(pi/8): |Im z| < -Re z tan(3 pi/8)). Printed answer, after
    ``gopt=msfsyn(Pnom,[3 1],[0 0 1 0],region)``: "-> optimal performance near 0"; the demo
    then sweeps the H-infinity levels "0.01, 0.1, 0.2, 0.5" for the nominal and the 4-vertex
    robust designs (their numbers are loaded from a data file, not printed).

    Duality (the layer designs observers): the state-feedback closed loop (A + B2 K, B1, C1)
    is the transpose of the observer error system of A_o = A^T, C_o = B2^T, E_o = C1^T,
    H = B1^T, D_o = D12^T = 0 with gain L = -K^T; transposition keeps the poles and the
    H-infinity norm, and the LMIs (common Lyapunov matrix for the norm and the region, as in
    ``msfsyn``) map one to one (P of the layer = X^-1 of the primal). The layer's min gamma
    on the dual must be "near 0": below 1e-3, a tenth of the smallest level the demo uses
    (computed 3.5e-5, limited by the solver; 0 is the infimum, not attained, so its backed-off
    design is at best 'inconclusive' and is not asserted). The demo's levels 0.5, 0.2, 0.1,
    0.01 must be certified, and 0.1 for the 4-vertex polytope (k, f at their bounds) with one
    common gain, as ``msfsyn``'s multi-model design. Independent checks: the primal
    state-feedback LMIs (X, Y = K X) written here in cvxpy give min gamma < 1e-3 too; the
    gain K = -L^T of the design at 0.1, mapped back, puts the closed-loop poles (numpy) in
    the region and its norm w -> x2 (frequency sweep, 4000 points) below 0.1.

    Catches: a sector with the sign of sin(theta) flipped (the cone then opens to the right
    and, with the half-plane, the design is infeasible: checked), a dual mapping with E_o and
    H swapped (the level 0.1 becomes infeasible: checked), a region or norm LMI that is not
    posed on the closed loop the gain produces (the mapped-back poles or peak fail)."""
    region = [InRegion(halfplane(0.1)), InRegion(sector(3 * np.pi / 8))]
    A, B = _satellite(0.245, 0.0188)
    c1 = np.array([[0.0, 1.0, 0.0, 0.0]])
    dual = PolytopicSystem(A.T, B.T, E=c1.T, H=B.T, name="sateldem (dual)")
    opt = ObserverSynthesis(dual, [BoundedReal()] + region).minimise(backoff=0.05)
    assert opt.optimum < 1e-3
    designs = {}
    for g in (0.5, 0.2, 0.1, 0.01):
        des = ObserverSynthesis(dual, [BoundedReal(gamma=g)] + region).solve()
        assert des.status == "certified", (g, des.certificate.reason())
        designs[g] = des
    # the gain of the 0.1 design, mapped back to state feedback, checked independently
    K = -designs[0.1].L[0].T
    Acl = A + B @ K
    ev = np.linalg.eigvals(Acl)
    assert np.all(ev.real < -0.1) and np.all(np.abs(ev.imag) < -ev.real * np.tan(3 * np.pi / 8))
    w = np.logspace(-3, 3, 4000)
    peak = max(abs((c1 @ np.linalg.solve(1j * wk * np.eye(4) - Acl, B))[0, 0]) for wk in w)
    assert peak < 0.1
    # robust multi-model design: the four vertices (k, f at their bounds), one gain
    verts = [_satellite(k, f) for k in (0.09, 0.4) for f in (0.0038, 0.04)]
    robust = PolytopicSystem([a.T for a, _ in verts], B.T, E=c1.T, H=B.T)
    des = ObserverSynthesis(robust, [BoundedReal(gamma=0.1)] + region).solve()
    assert des.status == "certified"
    # independent primal formulation (state feedback, X = P^-1, Y = K X), min gamma
    X = cp.Variable((4, 4), symmetric=True)
    Y = cp.Variable((1, 4))
    gam = cp.Variable()
    Z = A @ X + B @ Y
    zero = np.zeros((1, 1))
    brl = cp.bmat([[Z + Z.T, B, X @ c1.T], [B.T, -gam * np.eye(1), zero],
                   [c1 @ X, zero, -gam * np.eye(1)]])
    th = 3 * np.pi / 8
    sec = cp.bmat([[np.sin(th) * (Z + Z.T), np.cos(th) * (Z - Z.T)],
                   [np.cos(th) * (Z.T - Z), np.sin(th) * (Z + Z.T)]])
    cons = [X >> 1e-9 * np.eye(4), (brl + brl.T) / 2 << 0, Z + Z.T + 0.2 * X << 0,
            (sec + sec.T) / 2 << 0]
    prob = cp.Problem(cp.Minimize(gam), cons)
    prob.solve(solver="CLARABEL")
    assert prob.status == cp.OPTIMAL and gam.value < 1e-3


def test_printed_gain_with_unreachable_speed_is_infeasible_for_the_layer():
    """Wang (2018) Example 1 again (data as in the Example 1 test): the converse of the
    reproduction. Positivity (T A - L C >= 0) bounds how fast the error can contract; the
    layer must declare infeasible a contraction the structure cannot reach, not return an
    uncertified gain. The bound is computed independently here: with C = [1, 0] the gain only
    moves the first column of G = T A - L C, and G[0, 1] = (T A)[0, 1] = 0.01666, G[1, 1] =
    (T A)[1, 1] = 0.01058 are fixed and >= 0; for a nonnegative 2 x 2 matrix rho(G) >= the
    largest diagonal entry, so rho >= 0.01058 for every cooperative gain.

    Catches: a design that drops the Metzler rows when a region is also posed, or that
    returns the solver's point without the certificate's verdict."""
    A = np.array([[0.3, -0.7], [0.6, -0.5]])
    C = np.array([[1.0, 0.0]])
    T = np.array([[-0.0238, 0.0], [-0.7294, 1.0]])
    At = T @ A
    bound = At[1, 1]
    assert bound == pytest.approx(0.01058, abs=1e-5)
    system = PolytopicSystem(At, C, time="discrete")
    with pytest.raises(InfeasibleDesign):
        ObserverSynthesis(system, [InRegion(unit_disk(0.9 * bound)), Metzler(diag_shift=1e-9)],
                          P="diagonal").solve()
    assert not _cvxpy_positive_schur_design(At, C, 0.9 * bound)
    # without the positivity structure the same speed is reachable (any pole placement)
    free = ObserverSynthesis(system, [InRegion(unit_disk(0.9 * bound))]).solve()
    assert free.status == "certified"


def test_chen_patton_zhang_1996_jet_engine_robust_fault_detection_filter():
    """J. Chen, R. J. Patton & H.-Y. Zhang (1996), "Design of unknown input observers and
    robust fault detection filters", International Journal of Control 63(1), 85-105: the
    original full-order UIO (their eq. (2)-(8), Theorem 1) and its example of Sec. 4, the
    jet-engine model linearised at N_L = 450 rpm (3 states, 6 measurements).

    Read in the paper itself (scanned PDF held in the public repository
    Zichen-Yan/Unknown-input-Observer, file "reference paper/Design of unknown input observers
    and robust fault detection filters.pdf", commit 7a52900; pages 99 and 101 read as page
    images at 300 dpi). Printed data: A = [-1.5581 0.6925 0.3974; 0.2619 -2.2228 0.2238;
    0 0 -10], C = [I_3; 0.55107 0.13320 0.30603; 0.55217 0.13526 0.32912; -0.25693 -0.23625
    0.61299], E_1 = [6.2006 2.8639; 4.1048 -4.3262; 0 0]; "All eigenvalues of the robust
    fault detection filter are set to -3"; with the design procedure (H from their (11),
    H* = E [(C E)^T C E]^-1 (C E)^T; T = I - H C (6); A_1 = T A (13); K_1 = (A_1 + 3 I) C^+
    (25), "where C^+ is the pseudo-inverse of C"; F = A_1 - K_1 C (7); K = K_1 + F H (4), (8)),
    printed: H = [0.6117 -0.1170 0 0.3215 0.3220 -0.1295; -0.1170 0.9382 0 0.0605 0.0623
    -0.1916; 0 ... 0], T = [0 0 -0.1251; 0 0 0.0783; 0 0 1.0000], K = [-0.0708 0.0443 0.5658
    0.1400 0.1531 0.3540; 0.0443 -0.0277 -0.3540 -0.0876 -0.0958 -0.2215; 0.5658 -0.3540
    -4.5229 -1.1193 -1.2239 -2.8297].

    The layer: ``uio_system`` (H = E (C E)^+, the minimum-norm solution, equal to (11) for a
    full-column-rank C E) gives H to 5e-5 (the printed rounding; computed 4.9e-5). T = I - H C
    is printed inconsistently with the printed H and C by 1.3e-4 (computed here from the
    printed numbers alone), so T is checked to 2e-4. ``Decoupling.gains`` with the paper's
    K_1 gives F = -3 I (the printed pole assignment, exactly: C^+ C = I) and K within 4e-3 of
    the printed K (computed gap 3.7e-3, all in the third row and column; rounding the printed
    A, C, E_1 at their last digit moves K by at most 3.3e-5, measured by perturbation, so the
    gap is in the paper's arithmetic, not in the rounding: a tolerance of 0.1 % of the largest
    entry, |K| = 4.52, that a structural mistake exceeds by orders of magnitude). The layer's
    data certificate of K_1 on the decoupled system certifies decay 2.9 and calls 3.1
    'violated' (the poles are all at -3). Independent checks: the minimum-Frobenius-norm H
    with H C E_1 = E_1 by cvxpy equals the printed H; numpy eigenvalues of F.

    Catches: a decoupling that is not the minimum-norm solution (another H with H C E = E
    differs from the printed one by O(1): there are 4 free directions per row), K without
    the F H term (it would equal K_1, 2.8 away from the printed K), K_1 computed on A instead
    of T A (F would not be -3 I), a decay certificate with the wrong factor on P."""
    A = np.array([[-1.5581, 0.6925, 0.3974], [0.2619, -2.2228, 0.2238], [0.0, 0.0, -10.0]])
    C = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0.55107, 0.13320, 0.30603],
                  [0.55217, 0.13526, 0.32912], [-0.25693, -0.23625, 0.61299]])
    E1 = np.array([[6.2006, 2.8639], [4.1048, -4.3262], [0.0, 0.0]])
    H_pr = np.array([[0.6117, -0.1170, 0, 0.3215, 0.3220, -0.1295],
                     [-0.1170, 0.9382, 0, 0.0605, 0.0623, -0.1916], [0, 0, 0, 0, 0, 0]])
    T_pr = np.array([[0.0, 0.0, -0.1251], [0.0, 0.0, 0.0783], [0.0, 0.0, 1.0]])
    K_pr = np.array([[-0.0708, 0.0443, 0.5658, 0.1400, 0.1531, 0.3540],
                     [0.0443, -0.0277, -0.3540, -0.0876, -0.0958, -0.2215],
                     [0.5658, -0.3540, -4.5229, -1.1193, -1.2239, -2.8297]])
    # the printed T and H satisfy T = I - H C only to 1.3e-4: the tolerance on T
    assert np.abs(T_pr + H_pr @ C - np.eye(3)).max() == pytest.approx(1.3e-4, abs=1e-5)

    system, dec = uio_system(PolytopicSystem(A, C), E1)
    np.testing.assert_allclose(dec.H, H_pr, atol=PRINTED)
    np.testing.assert_allclose(dec.T, T_pr, atol=2e-4)
    assert dec.residual <= 1e-12
    K1 = (system.A[0] + 3.0 * np.eye(3)) @ np.linalg.pinv(C)      # the paper's (25)
    Fm, Km, _ = dec.gains(A, np.zeros((3, 1)), K1, C)
    np.testing.assert_allclose(Fm, -3.0 * np.eye(3), atol=1e-9)
    assert np.abs(Km - K_pr).max() <= 4e-3
    assert np.abs(K1 - K_pr).max() > 1.0                 # the F H term matters
    # independent: minimum-norm H by cvxpy, eigenvalues by numpy
    Hv = cp.Variable((3, 6))
    cp.Problem(cp.Minimize(cp.norm(Hv, "fro")), [Hv @ C @ E1 == E1]).solve(solver="CLARABEL")
    np.testing.assert_allclose(Hv.value, H_pr, atol=1e-4)
    np.testing.assert_allclose(np.linalg.eigvals(Fm).real, [-3.0] * 3, atol=1e-9)
    # the layer's data certificate of the printed design (poles at -3)
    P = 2.0 * np.eye(3)
    ok = certify_observer(ObserverSynthesis(system, [Decay(2.9)]), P, K1[None])
    assert ok.status == "certified", ok.reason()
    late = certify_observer(ObserverSynthesis(system, [Decay(3.1)]), P, K1[None])
    assert late.status == "violated" and late.pole_failures


def test_efimov_2013_discrete_interval_observer_change_of_coordinates():
    """D. Efimov, W. Perruquetti, T. Raissi & A. Zolghadri (2013), "On interval observer
    design for time-invariant discrete-time systems", European Control Conference (ECC),
    Zurich, pp. 2651-2656, Sec. IV.A "Comparison of observers (4) and (5)": A = [0.3 -0.7;
    0.6 -0.5], C = [1 0] (the data of Wang 2018 Ex. 1 above). Their Theorem 2 uses the
    time-invariant change of coordinates z = S^-1 x of Raissi, Efimov & Zolghadri (2012)
    (Lemma 2: R = S (A - L C) S^-1 for a "R in R_+^{n x n}" with the eigenvalues of A - L C);
    their Theorem 3 / Corollary 1 keeps the coordinates and asks |A - L C| Schur.

    Read in the paper itself (PDF held in the public repository BonhomieStriker/Interval-
    Observer, file "references/On interval observer design for time-invariant discrete-time
    systems.pdf", commit 84ac18d; text extracted with pdftotext, the matrices checked on the
    page image), p. 2654-2655: "there is no observer gain L in R^2 making the matrix D = A - L C
    nonnegative. The matrix A is Schur stable (it has complex eigenvalues), but the matrix
    A+ + A- is unstable. Applying Matlab YALMIP toolbox we obtain L = [0.3 0.6]^T, then
    lambda(D) = [0 -0.5]^T and lambda(D+ + D-) = [0 0.5]^T", "The matrices R = [-0.5 0; 1 0],
    S = [0.609 0.814; -1.162 0.581] satisfy to all conditions of Theorem 2".

    What the layer computes: its cooperative discrete-time design (unit disk + entry-wise
    nonnegative A - L C, diagonal P: the paper's Corollary 1, LMIs (7)-(8)) is infeasible, as
    printed (independent cvxpy formulation and the structural reason: L moves only the first
    column, (A - L C)[:, 1] = [-0.7, -0.5] stays negative); the printed L gives lambda(D) =
    {0, -0.5} and lambda(|D|) = {0, 0.5} exactly as printed, and the layer certifies Theorem
    3's condition on Sigma = [[D+, D-], [D-, D+]] (nonnegative, spectral radius 0.5: disk 0.55
    certified, 0.45 violated; P diagonal found by cvxpy). The change of coordinates:
    ``PolytopicSystem.transformed(S)`` (x~ = S^-1 x, gain S^-1 L) turns D into [0 0; 1 -0.5]
    within 2e-3 (computed gap 5.4e-4; rounding S at its 3rd decimal moves it by up to 1.6e-3,
    measured by perturbation), which is the printed R with its diagonal entries swapped
    (|difference| = 0.5): the printed R and S are not consistent with each other. Neither is
    nonnegative: both have the entry -0.5 on the diagonal. They are Metzler (the continuous-
    time cooperativity of Raissi et al. 2012) but not the "R in R_+" the discrete-time Theorem 2
    asks, and none can be: by Perron-Frobenius a nonnegative matrix has its spectral radius
    (here 0.5) as an eigenvalue, and {0, -0.5} does not contain 0.5. The layer's certificate
    says so by name (Metzler with diag_shift: 'metzler diag' violated) while the continuous-
    time Metzler check accepts R. The method itself works when its hypothesis holds: a gain
    giving D the eigenvalues of the nonnegative R2 = [0.1 0.05; 0.05 0.2] (scipy place_poles)
    and S2 = V_D V_R^-1 (eigenvector matrices) give S2^-1 D S2 = R2, which the same
    certificate accepts (disk 0.25, P diagonal by cvxpy).

    Catches: a discrete-time positivity check that looks only at off-diagonal entries (it
    would accept the printed R), a transformation with S and S^-1 swapped (the transformed
    matrix would be S D S^-1 = [-0.745 -0.390; 0.468 0.245], 0.53 away), a cooperative design
    that returns a gain where none exists."""
    from scipy.signal import place_poles

    A = np.array([[0.3, -0.7], [0.6, -0.5]])
    C = np.array([[1.0, 0.0]])
    L = np.array([[0.3], [0.6]])
    R_pr = np.array([[-0.5, 0.0], [1.0, 0.0]])
    S_pr = np.array([[0.609, 0.814], [-1.162, 0.581]])
    # printed facts about A
    lam = np.linalg.eigvals(A)
    assert np.all(np.abs(lam.imag) > 0.1) and np.abs(lam).max() < 1.0
    assert np.abs(np.linalg.eigvals(np.abs(A))).max() > 1.0            # 1.0557
    # no cooperative gain: the layer's design and an independent formulation agree
    system = PolytopicSystem(A, C, time="discrete", name="Efimov 2013 IV.A")
    with pytest.raises(InfeasibleDesign):
        ObserverSynthesis(system, [InRegion(unit_disk(0.999)), Metzler(diag_shift=1e-9)],
                          P="diagonal").solve()
    assert not _cvxpy_positive_schur_design(A, C, 0.999)
    # the printed gain: spectra of D and |D| as printed
    D = A - L @ C
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(D).real), [-0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(np.abs(D)).real), [0.0, 0.5],
                               atol=1e-12)
    # Theorem 3: Sigma = [[D+, D-], [D-, D+]] nonnegative and Schur, certified by the layer
    Dp, Dm = np.maximum(D, 0.0), np.maximum(-D, 0.0)
    Sigma = np.block([[Dp, Dm], [Dm, Dp]])
    sig = PolytopicSystem(Sigma, np.zeros((1, 4)), time="discrete", name="Sigma")
    P = _diagonal_schur_certificate(Sigma / 0.55)
    zero = np.zeros((1, 4, 1))
    ok = certify_observer(ObserverSynthesis(sig, [InRegion(unit_disk(0.55)),
                                                  Metzler(diag_shift=1e-12)], P="diagonal"),
                          P, zero)
    assert ok.status == "certified", ok.reason()
    slow = certify_observer(ObserverSynthesis(sig, [InRegion(unit_disk(0.45))], P="diagonal"),
                            P, zero)
    assert slow.status == "violated"
    # Theorem 2: the printed change of coordinates, through the layer's transformation
    tr = system.transformed(S_pr)
    Lt = np.linalg.solve(S_pr, L)                                        # F = S^-1 L
    Rt = tr.A[0] - Lt @ tr.C[0]
    np.testing.assert_allclose(Rt, [[0.0, 0.0], [1.0, -0.5]], atol=2e-3)
    assert np.abs(Rt - R_pr).max() == pytest.approx(0.5, abs=2e-3)       # printed R differs
    assert np.abs(S_pr @ D @ np.linalg.inv(S_pr) - R_pr).max() > 0.4    # not S D S^-1 either
    # neither R is nonnegative: discrete-time positivity rejects by name, Metzler accepts
    for Rm in (R_pr, np.array([[0.0, 0.0], [1.0, -0.5]])):
        rsys = PolytopicSystem(Rm, np.zeros((1, 2)), time="discrete", name="R")
        Pr = 2.0 * np.eye(2)
        pos = certify_observer(ObserverSynthesis(rsys, [Metzler(diag_shift=1e-12)],
                                                 P="diagonal"), Pr, np.zeros((1, 2, 1)))
        assert pos.status == "violated"
        assert pos.lmi.worst().name.startswith("metzler diag"), pos.reason()
        met = certify_observer(ObserverSynthesis(rsys, [Metzler()], P="diagonal"), Pr,
                               np.zeros((1, 2, 1)))
        assert met.lmi.ok, met.reason()
    ev = np.linalg.eigvals(R_pr).real                 # Perron-Frobenius: rho not an eigenvalue
    assert not np.any(np.isclose(ev, np.abs(ev).max()))
    # where the hypothesis holds (real positive spectrum) the construction is certified:
    # a nonnegative R2, a gain giving A - L2 C its eigenvalues, S2 = V_D V_R^-1 (Lemma 2)
    R2 = np.array([[0.1, 0.05], [0.05, 0.2]])
    lr, Vr = np.linalg.eigh(R2)
    L2 = place_poles(A.T, C.T, lr).gain_matrix.T
    ld, Vd = np.linalg.eig(A - L2 @ C)
    Vd = Vd[:, np.argsort(ld.real)].real
    S2 = Vd @ np.linalg.inv(Vr)
    tr2 = system.transformed(S2)
    Lt2 = np.linalg.solve(S2, L2)
    np.testing.assert_allclose(tr2.A[0] - Lt2 @ tr2.C[0], R2, atol=1e-9)
    P2 = _diagonal_schur_certificate(R2 / 0.25)
    good = certify_observer(ObserverSynthesis(tr2, [InRegion(unit_disk(0.25)),
                                                    Metzler(diag_shift=1e-12)], P="diagonal"),
                            P2, Lt2[None])
    assert good.status == "certified", good.reason()
