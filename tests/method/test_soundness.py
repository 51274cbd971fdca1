"""Statistical soundness of the default identification under output noise.

The plant: two lightly coupled pole pairs, 2 outputs, 2 inputs, generic observability
indices (2, 2) (docs/uncertainty.md §6). Under white output noise its least-squares
models are biased, and the greedy step reaches order 4 through the list (1, 3), which
cannot represent it: the checks below are against the known truth.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given
from hypothesis import strategies as st

import moli
from moli.method.refinement.levenberg_marquardt import refine
from moli.method.uncertainty.refined_covariance import refined_covariance
from moli.method.structure.indices import generic_indices

OMEGA = np.linspace(0.05, 3.0, 12)
NOISE = 0.3          # against outputs of standard deviation 2.0 and 1.8


def two_by_two() -> moli.StateSpaceModel:
    def rotation(z: complex) -> np.ndarray:
        return np.array([[z.real, z.imag], [-z.imag, z.real]])

    A = scipy.linalg.block_diag(rotation(0.8 * np.exp(0.4j)), rotation(0.6 * np.exp(1.2j)))
    B = np.array([[1.0, 0.3], [0.5, -0.4], [-0.2, 1.0], [0.7, 0.6]])
    C = np.array([[1.0, 0.0, 0.4, 0.2], [0.3, -0.5, 1.0, 0.0]])
    return moli.StateSpaceModel(A, B, C)


def record(truth: moli.StateSpaceModel, N: int, seed: int) -> moli.IOData:
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, truth.m))
    return moli.IOData(truth.simulate(u) + NOISE * rng.standard_normal((N, truth.p)), u)


def gain(model: moli.StateSpaceModel) -> np.ndarray:
    return np.abs(model.frequency_response(OMEGA))


def identified(N: int, seed: int, **options: object) -> moli.IdentificationResult:
    est, val = record(two_by_two(), N + N * 2 // 3, seed).split(N)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return moli.identify(est, val, **options)


def relative_gain_error(model: moli.StateSpaceModel) -> float:
    truth = gain(two_by_two())
    return float(np.median(np.abs(gain(model) - truth) / truth))


def test_guarded_refinement_finds_the_list_the_plant_needs():
    for seed in (0, 2, 3):          # records on which the least squares take the wrong list
        # the greedy step's least squares rank (1, 3) first at order 4 ...
        assert identified(600, seed, order=4, refine="none").model.indices == (1, 3)
        # ... but only (2, 2) represents the plant: its refinement wins on validation
        result = identified(600, seed, order=4)
        assert result.model.indices == (2, 2)
        # within a few standard errors of the truth (about 0.01 at this length)
        assert relative_gain_error(result.model) < 0.05


def test_default_gain_error_shrinks_with_the_record():
    # a consistent estimate: ten times the samples divides the error by about sqrt(10);
    # the least squares alone, or a list that cannot hold the plant, stays near 0.03-0.04
    short = np.median([relative_gain_error(identified(500, seed, order=4).model) for seed in range(4)])
    long = np.median([relative_gain_error(identified(5000, seed, order=4).model) for seed in range(4)])
    assert long < 0.5 * short and long < 0.02


def test_refined_order_rule_finds_the_order_of_a_noisy_plant():
    orders = [identified(600, seed, order_rule="refined").model.n for seed in range(5)]
    # the order rules on the least-squares path alone pick 5-10 here (their bias is bought
    # back by extra states); the one-standard-error test passes at the true order
    assert sum(order == 4 for order in orders) >= 4, orders


@pytest.mark.parametrize("ridge", [0.0, 1.0])
def test_refined_covariance_predicts_the_spread_of_refined_estimates(ridge):
    # a ridge's model gets the free problem's covariance: with its penalty counted as
    # information the predicted standard deviation was 0.3 of the actual, coverage 0.43
    truth = moli.StateSpaceModel([[1.6 * np.cos(0.4), -0.64], [1.0, 0.0]], [[1.0], [0.0]], [[1.0, 0.5]])
    alpha = moli.filter_polynomial(0.45, 0.7, [2])
    gains, predicted = [], []
    for seed in range(40):
        data = record(truth, 500, seed).remove_means()
        model = refine(moli.estimate(data, [2], alpha), data, ridge=ridge).model
        assert model.info["refine_iterations"] > 0
        attached = moli.estimate_covariance(model, data)
        assert attached.info["covariance"]["method"].startswith("output-error")
        lower, upper = attached.magnitude_bands(OMEGA)
        gains.append(gain(model))
        predicted.append((upper - gains[-1]) / 1.959963984540054)
    ratio = np.mean(predicted, axis=0) / np.std(gains, axis=0)
    # 40 records: the actual standard deviation is known to about 1/sqrt(78) = 11 %
    # relative; 0.7-1.4 is three of those standard errors either side of 1
    assert 0.7 < np.median(ratio) < 1.4
    truth_gain = gain(truth)
    inside = [np.mean((g - 1.96 * s <= truth_gain) & (truth_gain <= g + 1.96 * s)) for g, s in zip(gains, predicted)]
    # 95 % bands; 40 correlated records: anything from 0.85 on is within their error
    assert 0.85 <= np.mean(inside) <= 1.0


def test_directions_that_change_no_response_leave_the_bands_finite():
    data = record(two_by_two(), 1000, 3).remove_means()
    for indices in ([2, 2], [1, 3]):
        start = moli.estimate(data, indices, moli.filter_polynomial(0.45, 0.7, indices))
        model = refine(start, data).model
        factor, info = refined_covariance(model, data)
        # 17 observer-form parameters (D_o 8, B 8, G 1)
        assert info["parameters"] == 17
        if indices == [2, 2]:
            # the generic list spans the whole family of 4th-order 2x2 systems without
            # feedthrough, n (p + m) = 16 dimensions: one parameter is redundant
            assert info["rank"] == 16
        else:
            assert info["rank"] < 16      # (1, 3) spans less: why it cannot hold this plant
        attached = moli.estimate_covariance(model, data)
        lower, upper = attached.magnitude_bands(OMEGA)
        assert np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)) and np.all(upper > lower)


def test_an_unstable_refined_model_has_no_covariance():
    data = record(two_by_two(), 400, 0).remove_means()
    model = refine(moli.estimate(data, [2, 2], moli.filter_polynomial(0.45, 0.7, [2, 2])), data).model
    unstable = model.with_matrices(1.2 * np.eye(4), model.B, model.C, model.D, dict(model.info), model.divisors)
    with pytest.raises(moli.DataError, match="stable"):
        refined_covariance(unstable, data)


def test_the_readme_example_and_the_demo_pass_their_own_checks():
    # the README's example: no order-bound warning, and residuals that pass its whiteness test
    est, val = moli.example_data(N=1000).split(600)
    with warnings.catch_warnings():
        warnings.simplefilter("error", moli.OrderBoundWarning)
        model = moli.identify(est, val, nmax=10).model
        # moli demo: the whole example record, half held out, the default order bound
        moli.identify(*moli.example_data().split(0.5))
    verdicts = moli.residual_analysis(model, val).verdicts
    assert all("residuals white" in verdict for verdict in verdicts), verdicts


def test_only_the_generic_list_holds_every_system_of_its_order():
    # the dimension of the p x m systems of order n (no feedthrough) is n (p + m); the rank
    # of the simulation error's Jacobian is the dimension of the family a list spans
    rng = np.random.default_rng(1)
    n, p, m = 5, 3, 3
    A = rng.standard_normal((n, n))
    truth = moli.StateSpaceModel(A * 0.8 / max(abs(np.linalg.eigvals(A))), rng.standard_normal((n, m)),
                                 rng.standard_normal((p, n)))
    u = rng.standard_normal((3000, m))
    data = moli.IOData(truth.simulate(u) + 0.01 * rng.standard_normal((3000, p)), u)
    ranks = {}
    for indices in [(2, 2, 1), (2, 1, 2), (1, 2, 2), (3, 1, 1)]:
        start = moli.estimate(data, list(indices), moli.filter_polynomial(0.45, 0.7, list(indices)))
        ranks[indices] = refined_covariance(refine(start, data, iterations=2).model, data)[1]["rank"]
    assert generic_indices(n, p) == (2, 2, 1)
    assert ranks[(2, 2, 1)] == n * (p + m)
    assert all(rank < n * (p + m) for indices, rank in ranks.items() if indices != (2, 2, 1)), ranks


@given(st.integers(1, 8), st.integers(0, 40))
def test_generic_indices_are_the_even_split_in_output_order(p, extra):
    n = p + extra                   # MOLI gives every output at least one index
    indices = generic_indices(n, p)
    assert sum(indices) == n and len(indices) == p
    assert list(indices) == sorted(indices, reverse=True) and indices[0] - indices[-1] <= 1


def test_bands_of_the_default_hold_every_channel_of_a_3x3_plant():
    # example_plant at its order: the greedy step reaches order 6 as (3, 1, 2), a family of
    # 34 dimensions where the plant needs 36, whose output-2 gains are biased; the generic
    # list (2, 2, 2) is consistent and its bands hold the truth at about 0.95 of the points
    truth = moli.example_plant()
    inside = []
    for seed in range(16):
        rng = np.random.default_rng(seed)
        u = rng.standard_normal((1000, 3))
        est, val = moli.IOData(truth.simulate(u) + NOISE * rng.standard_normal((1000, 3)), u).split(600)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = moli.identify(est, val, order=6).model
        lower, upper = model.magnitude_bands(OMEGA)
        inside.append((lower <= gain(truth)) & (gain(truth) <= upper))
    per_channel = np.mean(inside, axis=(0, 1))
    # on these 16 records the default before the generic list (13 of them (3, 1, 2)) held the
    # truth at 0.62 of its worst channel's points, now 0.88 (0.96 over all channels); 0.8
    # lies between the two
    assert per_channel.min() >= 0.8, per_channel


def test_the_default_finds_the_order_of_the_noisy_2x2_plant():
    # the greedy step reaches order 4 as (1, 3), whose biased least-squares model fits
    # validation worse than orders 5 and 6: the order rule alone selects one of those on
    # every record. The generic list (2, 2) of order 4, refined to its optimum, fits as well
    # as they do, and is kept. 29 of 30 records found the order in docs/uncertainty.md §5's
    # measurement, so 3 of these 4 leaves room for one record's chance.
    orders = [identified(600, seed).selected.order for seed in range(4)]
    assert sum(order == 4 for order in orders) >= 3, orders
    # a fixed order is the caller's: nothing steps down from it; without the orders below
    # (the fast preset) the order rule's choice stands
    assert identified(600, 0, order=5).selected.order == 5
    assert identified(600, 0, lower_orders=False).selected.order > 4
