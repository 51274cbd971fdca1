"""Ridge least squares with the weight chosen by GCV, against a direct computation."""

import numpy as np
import pytest

import moli
from moli.method.least_squares.regularization import RELATIVE_WEIGHTS, ridge_gcv
from systems_util import plant_record


def _brute_force(phi: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Ridge on the full regression: explicit hat matrix for GCV, augmented lstsq to solve."""
    norms = np.linalg.norm(phi, axis=0)
    scaled = phi / norms
    n, q = scaled.shape
    top = np.linalg.svd(scaled, compute_uv=False)[0] ** 2
    best, best_theta = np.inf, None
    for weight in RELATIVE_WEIGHTS * top:
        augmented = np.vstack([scaled, np.sqrt(weight) * np.eye(q)])
        theta = np.linalg.lstsq(augmented, np.concatenate([y, np.zeros(q)]), rcond=None)[0]
        hat = scaled @ np.linalg.pinv(augmented)[:, :n]
        gcv = n * np.sum((y - scaled @ theta) ** 2) / (n - np.trace(hat)) ** 2
        if gcv < best:
            best, best_theta = gcv, theta
    return best_theta / norms


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("noise", [0.0, 0.3, 3.0])
def test_reduced_problem_gives_the_full_ridge_solution(seed, noise):
    # the reduced problem (R factor of [phi, y]) has the full problem's residual norms,
    # so GCV must pick the same weight and the same solution as the brute force on all
    # rows; 1e-8 relative: both routes solve the same well-conditioned small system
    rng = np.random.default_rng(seed)
    n, q = 60, 8
    phi = rng.standard_normal((n, q)) * np.logspace(-2, 2, q)
    phi[:, -1] = phi[:, 0] + 1e-3 * rng.standard_normal(n)      # nearly collinear columns
    y = phi @ rng.standard_normal(q) + noise * rng.standard_normal(n)
    r = np.linalg.qr(np.column_stack([phi, y]), mode="r")
    theta = ridge_gcv(r[None, :, :q], r[None, :, q], n)[0]
    expected = _brute_force(phi, y)
    assert np.allclose(phi @ theta, phi @ expected, rtol=1e-8, atol=1e-8 * np.linalg.norm(y))


def test_exact_data_are_not_shrunk():
    # noise-free data: the zero weight has zero residual, so GCV keeps plain least squares
    rng = np.random.default_rng(1)
    phi = rng.standard_normal((40, 5))
    truth = rng.standard_normal(5)
    r = np.linalg.qr(np.column_stack([phi, phi @ truth]), mode="r")
    assert np.allclose(ridge_gcv(r[None, :, :5], r[None, :, 5], 40)[0], truth, rtol=1e-9)


def test_noise_free_system_recovered_with_gcv():
    # a known 3x3 order-6 plant without noise: the regularized estimate of the true
    # structure must still be the plant (GCV's zero weight has zero residual); its
    # response to a fresh input from rest matches the plant's to 1e-6 of the output
    # scale (least squares exact up to round-off, the filters' conditioning aside)
    y, u, (A, B, C) = plant_record(1200, 0.0, seed=3)
    est, val = moli.IOData(y, u).split(800)
    result = moli.identify(est, val, nmax=6, order=6, regularization="gcv", refine="none",
                           noise_model=False, center=False)
    fresh = np.random.default_rng(9).standard_normal((500, 3))
    truth = moli.StateSpaceModel(A, B, C).simulate(fresh)
    assert np.max(np.abs(result.model.simulate(fresh) - truth)) < 1e-6 * np.max(np.abs(truth))


def test_unknown_regularization_is_refused():
    with pytest.raises(moli.OptionError, match="regularization"):
        moli.IdentifyOptions(regularization="lasso")
