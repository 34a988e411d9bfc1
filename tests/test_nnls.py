"""The batched Lawson-Hanson solver against SciPy's and against the optimality conditions."""

import numpy as np
import pytest

from mjmotion import nnls


@pytest.mark.parametrize("n", [1, 3, 6, 7, 24, 48])
def test_solve_is_scipys_nnls_on_random_problems(n):
    from scipy.optimize import nnls as scipy_nnls

    rng = np.random.default_rng(n)
    r_count, m = 200, 6
    a = rng.normal(size=(r_count, m, n))
    b = rng.normal(size=(r_count, m)) * rng.uniform(0.1, 10.0, (r_count, 1))
    allowed = rng.random((r_count, n)) < 0.7
    sol = nnls.solve(a, b, allowed)
    assert sol.x.shape == (r_count, n) and np.all(sol.x >= 0) and np.all(sol.x[~allowed] == 0)
    for r in range(r_count):
        cols = np.flatnonzero(allowed[r])
        ref = scipy_nnls(a[r][:, cols], b[r])[1] if len(cols) else np.linalg.norm(b[r])
        assert sol.residual[r] == pytest.approx(ref, abs=1e-10)
    assert np.allclose(sol.residual, np.linalg.norm(np.einsum("rmn,rn->rm", a, sol.x) - b, axis=1))


def test_solution_meets_the_kkt_conditions():
    """x ≥ 0; the dual w = Aᵀ(b − Ax) is ≤ 0 on the allowed columns at 0 and 0 on the positive ones."""
    rng = np.random.default_rng(5)
    a = rng.normal(size=(300, 6, 20))
    a[:, 2] = np.abs(a[:, 2])  # cone-like generators, as the friction pyramids are
    b = rng.normal(size=(300, 6))
    sol = nnls.solve(a, b)
    w = np.einsum("rmn,rm->rn", a, b - np.einsum("rmn,rn->rm", a, sol.x))
    pos = sol.x > 0
    assert np.abs(w[pos]).max() < 1e-9
    assert w[~pos].max() < 1e-9


def test_known_answers_and_degenerate_problems():
    a = np.array([[[1.0, 0.0], [0.0, 1.0]]] * 5)
    b = np.array([[2.0, 3.0], [-2.0, 3.0], [-1.0, -1.0], [0.0, 0.0], [2.0, -4.0]])
    sol = nnls.solve(a, b)
    assert np.allclose(sol.x, [[2, 3], [0, 3], [0, 0], [0, 0], [2, 0]])
    assert np.allclose(sol.residual, [0, 2, np.sqrt(2), 0, 4])
    # No allowed column: the whole right-hand side is left over.
    none = nnls.solve(a, b, np.zeros((5, 2), dtype=bool))
    assert np.allclose(none.residual, np.linalg.norm(b, axis=1)) and not none.x.any()
    # Repeated columns (two contact points at one place) do not break the active set.
    dup = np.repeat(np.random.default_rng(2).normal(size=(50, 6, 4)), 3, axis=2)
    rhs = np.einsum("rmn,rn->rm", dup, np.abs(np.random.default_rng(3).normal(size=(50, 12))))
    assert np.all(nnls.solve(dup, rhs).residual < 1e-9)  # inside the cone: supplied exactly
