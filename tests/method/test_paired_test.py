"""The paired test of two models' validation errors: correlation time, batches, level."""

import numpy as np
import pytest
import scipy.signal
import scipy.stats

from moli.method.selection.paired_test import (BATCH_TIMES, MIN_BATCHES, PAIRED_BATCHES, correlation_time,
                                     paired_difference)


def _ar1(rng, n, pole, burn_in=300):
    """A stationary AR(1) series of unit variance (the filter's start forgotten in the burn-in)."""
    e = rng.standard_normal(n + burn_in) * np.sqrt(1 - pole ** 2)
    return scipy.signal.lfilter([1.0], [1.0, -pole], e)[burn_in:]


@pytest.mark.parametrize("pole", [0.0, 0.5, 0.8])
def test_correlation_time_of_ar1_series_is_the_known_one(pole):
    # An AR(1) series of pole a has the integrated correlation time (1 + a) / (1 - a): 1, 3, 9.
    # Sokal's windowed estimate on 40000 samples has a relative standard error of
    # sqrt(2 (2M + 1) / n) with M about 5 tau: 2-7 %; 30 % is four of them at the worst.
    rng = np.random.default_rng(3)
    truth = (1 + pole) / (1 - pole)
    assert correlation_time(_ar1(rng, 40000, pole)) == pytest.approx(truth, rel=0.3)


def test_correlation_time_of_a_constant_or_tiny_series():
    # constants (0.1 is not exact in binary: its mean may round) and two samples, whose one
    # lag's autocorrelation is -1/2: nothing correlated
    assert correlation_time(np.zeros(50)) == 1.0
    assert correlation_time(np.full(100, 0.1)) == 1.0
    assert correlation_time(np.array([1.0, 2.0])) == 1.0


def test_equal_shifts_keep_ten_batches():
    # one model worse by the same amount at every sample: the spread of the batch sums is zero
    worse, margin = paired_difference(np.full(100, 0.3), np.full(100, 0.2), 1.0)
    assert worse == pytest.approx(10.0, rel=1e-12)
    assert margin == pytest.approx(0.0, abs=1e-12)


def test_ten_batches_where_the_differences_are_white():
    # A long white record keeps the ten contiguous batches: the margin is z times the
    # standard deviation of the ten batch sums (ddof 1, times the square root of ten),
    # computed here independently of the module.
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(1000) ** 2, rng.standard_normal(1000) ** 2
    worse, margin = paired_difference(a, b, 2.0)
    sums = np.array([np.sum(part) for part in np.array_split(a - b, PAIRED_BATCHES)])
    assert worse == pytest.approx(np.sum(a - b), rel=1e-12)
    assert margin == pytest.approx(2.0 * np.sqrt(PAIRED_BATCHES) * np.std(sums, ddof=1), rel=1e-12)


def test_fewer_batches_widen_the_margin_at_the_same_level():
    # Strongly correlated differences on a short record: fewer than ten batches, and the
    # threshold is Student's t quantile of the ten-batch tail at their degrees of freedom,
    # above z (heavier tails with fewer batches).
    rng = np.random.default_rng(1)
    a = _ar1(rng, 80, 0.95) ** 2
    b = _ar1(rng, 80, 0.95) ** 2
    tau = correlation_time(a - b)
    count = max(MIN_BATCHES, int(80 // (BATCH_TIMES * tau)))
    assert count < PAIRED_BATCHES
    sums = np.array([np.sum(part) for part in np.array_split(a - b, count)])
    spread = np.sqrt(count) * np.std(sums, ddof=1)
    threshold = scipy.stats.t.isf(scipy.stats.t.sf(1.0, PAIRED_BATCHES - 1), count - 1)
    assert threshold > 1.0
    assert paired_difference(a, b, 1.0)[1] == pytest.approx(threshold * spread, rel=1e-12)


def test_a_diverging_model_never_passes():
    # a simulation that diverges has infinite error shares: it loses to a finite model, and
    # the order rule passes over it even where any finite loss would be negligible
    from types import SimpleNamespace

    from moli.method.selection.order_rules import select_by_shares

    diverging = np.ones(100)
    diverging[40] = np.inf
    worse, _ = paired_difference(diverging, np.ones(100), 1.0)
    assert worse == np.inf
    shares = (diverging, np.ones(100))
    path = [SimpleNamespace(order=k + 1, stable=True, mean_vaf=v) for k, v in enumerate((40.0, 50.0))]
    assert select_by_shares(path, lambda i: shares[i], z=1.0) == 1
    assert select_by_shares(path, lambda i: shares[i], z=1.0, negligible=1e9) == 1
    # the same lower order with finite errors a little worse is kept at that tolerance
    shares = (np.full(100, 1.01), np.ones(100))
    assert select_by_shares(path, lambda i: shares[i], z=1.0, negligible=1e9) == 0


@pytest.mark.parametrize("pole, samples", [(0.9, 67), (0.9, 126), (0.0, 67)])
def test_two_equally_good_models_are_told_apart_at_the_tests_level(pole, samples):
    # Monte Carlo of the test's size (benchmarks/paired_test_size.py): each model's error is
    # a shared noise plus a misfit of its own, all AR(1) of the same pole, so neither model
    # is better. The one-sided rate at which the second is declared better by z = 2 must be
    # the nominal 0.038 of Student's t with nine degrees of freedom. With ten fixed batches
    # (7 samples each under pole 0.9) this set-up gave 0.090 on 67 samples; on 126 samples the
    # two differ less (0.065 against 0.034). 1500 records give a binomial standard error of
    # 0.005; the bounds [0.015, 0.065] are about five of them either side.
    rng = np.random.default_rng(7)
    declared = 0
    records = 1500
    for _ in range(records):
        shared = _ar1(rng, samples, pole)
        first = (shared + _ar1(rng, samples, pole)) ** 2
        second = (shared + _ar1(rng, samples, pole)) ** 2
        worse, margin = paired_difference(first, second, 2.0)
        declared += worse > margin
    assert 0.015 <= declared / records <= 0.065
