"""The refinement's damped steps: normal equations where the Gram matrix's round-off allows, QR otherwise."""

import numpy as np
import pytest

from moli.method.refinement.damped_steps import GRAM_ROUNDOFF_SHARE, Linearization


def ill_conditioned(rows: int, k: int, seed: int) -> np.ndarray:
    """``[J, r]`` with column scales over six decades and singular values over ten (as the
    refinement's Jacobians have: scaled condition numbers of 1e11 to 1e16 on the DaISy records)."""
    rng = np.random.default_rng(seed)
    u, _ = np.linalg.qr(rng.standard_normal((rows, k)))
    v, _ = np.linalg.qr(rng.standard_normal((k, k)))
    J = (u * np.logspace(0, -10, k)) @ v * np.logspace(-3, 3, k)
    return np.column_stack([J, rng.standard_normal(rows)])


def reference_step(augmented: np.ndarray, damping: float, penalty=None, target=None) -> np.ndarray:
    """The damped step from an SVD of the whole stacked problem, in units of the column norms."""
    J, r = augmented[:, :-1], augmented[:, -1]
    norms = np.linalg.norm(J, axis=0)
    k = J.shape[1]
    rows, rhs = [J / norms, np.sqrt(damping) * np.eye(k)], [r, np.zeros(k)]
    if penalty is not None:
        rows.append(np.diag(penalty))
        rhs.append(target)
    return np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]


@pytest.mark.parametrize("damping", [1e-9, 1e-6, 1e-3, 1.0])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_normal_equations_give_the_damped_step(damping, seed):
    augmented = ill_conditioned(1500, 40, seed)
    linearized = Linearization(augmented, 1e-9)
    assert linearized.uses_normal_equations(damping)
    step = linearized.step(damping)
    expected = reference_step(augmented, damping)
    # the Gram matrix's round-off moves the solution by at most rows * eps / damping relative
    # (module docstring): 3e-4 at the floor; a tenth of that at most is seen on these matrices
    bound = max(augmented.shape[0] * np.finfo(float).eps / damping, 1e-10)
    assert np.linalg.norm(step - expected) <= 10 * bound * np.linalg.norm(expected)


def test_the_ridge_rows_enter_the_normal_equations():
    augmented = ill_conditioned(800, 30, 3)
    rng = np.random.default_rng(4)
    penalty, target = rng.uniform(0.1, 2.0, 30), rng.standard_normal(30)
    step = Linearization(augmented, 1e-9).step(1e-4, penalty, target)
    expected = reference_step(augmented, 1e-4, penalty, target)
    # rows * eps / damping = 2e-9 relative, with room for the SVD's own round-off
    assert np.linalg.norm(step - expected) <= 1e-7 * np.linalg.norm(expected)


def test_a_damping_below_the_gram_roundoff_takes_the_qr():
    augmented = ill_conditioned(3000, 20, 5)
    # the threshold damping of 3000 rows: rows * eps / share
    threshold = 3000 * np.finfo(float).eps / GRAM_ROUNDOFF_SHARE
    linearized = Linearization(augmented, threshold / 100)
    assert not linearized.uses_normal_equations(threshold / 10)
    assert linearized.uses_normal_equations(threshold * 10)
    step = linearized.step(threshold / 10)
    expected = reference_step(augmented, threshold / 10)
    # a QR of the stacked problem is backward stable: its condition (about 1 / sqrt(damping), 1e6 here) times eps
    assert np.linalg.norm(step - expected) <= 1e-8 * np.linalg.norm(expected)


def test_a_linearization_that_is_not_finite_says_so():
    augmented = ill_conditioned(200, 10, 6)
    augmented[17, 3] = np.nan
    assert not Linearization(augmented, 1e-9).finite


def test_a_normal_system_that_fails_its_cholesky_defers_to_the_qr_or_to_a_larger_damping(monkeypatch):
    import scipy.linalg

    def not_positive_definite(*args, **kwargs):
        raise np.linalg.LinAlgError("not positive definite")

    monkeypatch.setattr(scipy.linalg, "cho_factor", not_positive_definite)
    augmented = ill_conditioned(3000, 20, 7)
    threshold = 3000 * np.finfo(float).eps / GRAM_ROUNDOFF_SHARE
    # the floor needs the QR at small dampings, so the matrix is kept and the QR answers
    kept = Linearization(augmented, threshold / 100)
    expected = reference_step(augmented, threshold * 10)
    assert np.linalg.norm(kept.step(threshold * 10) - expected) <= 1e-8 * np.linalg.norm(expected)
    # every damping from the floor on is solved from the Gram matrix: no QR at hand, so no step
    assert Linearization(augmented, threshold * 10).step(threshold * 10) is None
