"""What the record supports of each pole: the modulus interval and the time constant."""

from __future__ import annotations

import numpy as np

import moli
from moli.app.figures import settling_samples
from moli.models.pole_bands import pole_support


def _model(A, factor):
    n = A.shape[0]
    return moli.StateSpaceModel(A, np.ones((n, 1)), np.ones((1, n)), cov_factor=factor)


def test_the_modulus_interval_matches_draws_of_the_matrices():
    # independent truth: the spread of |eig(A)| over draws of A from the same normal law; small
    # perturbations, so the first-order interval and the draws agree to a few percent
    rng = np.random.default_rng(0)
    A = np.array([[0.9, 0.2, 0.0], [-0.2, 0.9, 0.1], [0.0, 0.0, 0.6]])
    factor = np.zeros((9 + 3 + 3 + 1, 5))
    factor[:9] = 1e-3 * rng.standard_normal((9, 5))
    supports = pole_support(_model(A, factor))
    draws = A + (factor[:9] @ rng.standard_normal((5, 20000))).T.reshape(-1, 3, 3)
    moduli = np.sort(np.abs(np.linalg.eigvals(draws)), axis=1)       # ascending, as are the poles below
    q = 1.959963984540054
    for s in supports:
        j = int(np.argmin(np.abs(np.sort(np.abs(np.linalg.eigvals(A))) - abs(s.pole))))
        sd = (s.upper - abs(s.pole)) / q
        # 20000 draws estimate an sd to 0.5 %; the first-order law is exact to O(1e-3) here
        assert abs(np.std(moduli[:, j]) / sd - 1) < 0.05


def test_a_pole_the_record_cannot_resolve_sets_no_step_horizon():
    # the demo's case: a pole at 0.999 whose interval reaches the unit circle, beside one at 0.9
    # (time constant 9.5 samples): the horizon is five of the latter's time constants
    factor = np.zeros((4 + 2 + 2 + 1, 1))
    factor[0] = 0.002
    model = _model(np.diag([0.999, 0.9]), factor)
    slow, fast = pole_support(model, record_samples=500)
    assert slow.reaches_unit_circle and slow.longer_than_record and not slow.supported
    assert fast.supported
    assert settling_samples(model, 500) == int(np.ceil(5 / -np.log(0.9)))
    # the same slow pole known to 1e-6 on a record of 20000 samples is resolved: it sets the horizon
    factor[0] = 1e-6
    assert settling_samples(_model(np.diag([0.999, 0.9]), factor), 20000) == 2000   # the cap


def test_without_a_covariance_only_the_record_length_rules():
    model = moli.StateSpaceModel(np.diag([0.99, 0.5]), np.ones((2, 1)), np.ones((1, 2)))
    assert all(np.isnan(s.upper) and not s.reaches_unit_circle for s in pole_support(model))
    assert settling_samples(model) == int(np.ceil(5 / -np.log(0.99)))
    # on 50 samples the pole at 0.99 (time constant 99.5) outlasts the record; 0.5 settles within the 20-sample floor
    assert settling_samples(model, 50) == 20
