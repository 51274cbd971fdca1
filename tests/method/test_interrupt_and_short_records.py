"""Ctrl-C after the greedy path, and records too short to choose an order."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from moli.method.pipeline import finishing, order_choice
from moli.method.pipeline.interruption import SELECTION_CHECKS
from moli.method.refinement import refined_steps
from moli.method.structure.rows import largest_order, samples_needed
from moli.method.selection.checks import SAMPLES_PER_PARAMETER, selection_samples_needed

NMAX = 4


@pytest.fixture(scope="module")
def halves() -> tuple[moli.IOData, moli.IOData]:
    return moli.example_data(N=500, seed=2).split(300)


def interrupt(*args, **kwargs):
    raise KeyboardInterrupt


def test_ctrl_c_in_the_covariance_keeps_the_refined_model(halves, monkeypatch):
    whole = moli.identify(*halves, nmax=NMAX)
    monkeypatch.setattr(finishing, "estimate_covariance", interrupt)
    cut = moli.identify(*halves, nmax=NMAX)
    assert cut.interrupted and cut.skipped == ("covariance", "noise model")
    assert cut.model.cov_factor is None and cut.model.K is None
    assert cut.model.info["interrupted"] == {"skipped": ["covariance", "noise model"]}
    # the same computation up to the cut: the same model to the bit
    np.testing.assert_array_equal(cut.model.A, whole.model.A)
    assert "interrupted: skipped covariance, noise model" in cut.summary()


def test_ctrl_c_after_the_noise_model_keeps_the_complete_model(halves, monkeypatch):
    # the model is complete once the noise model is attached: Ctrl-C during the checks of its
    # selection that follow (warnings only) skips them and keeps it
    whole = moli.identify(*halves, nmax=NMAX)
    monkeypatch.setattr(finishing, "warn_if_short_selection", interrupt)
    cut = moli.identify(*halves, nmax=NMAX)
    assert cut.interrupted and cut.skipped == (SELECTION_CHECKS,)
    assert cut.model.info["interrupted"] == {"skipped": [SELECTION_CHECKS]}
    assert cut.model.K is not None and cut.model.cov_factor is not None
    np.testing.assert_array_equal(cut.model.A, whole.model.A)


def test_ctrl_c_in_the_refinement_keeps_the_unrefined_model(halves, monkeypatch):
    unrefined = moli.identify(*halves, nmax=NMAX, refine="none")
    monkeypatch.setattr(refined_steps, "refine_each", interrupt)
    cut = moli.identify(*halves, nmax=NMAX)
    assert cut.skipped == ("refinement", "covariance", "noise model")
    assert cut.selected.indices == unrefined.selected.indices
    np.testing.assert_array_equal(cut.model.A, unrefined.model.A)


def test_ctrl_c_while_refining_the_path_selects_on_the_unrefined_path(halves, monkeypatch):
    unrefined = moli.identify(*halves, nmax=NMAX, refine="none")
    monkeypatch.setattr(refined_steps, "refine_each", interrupt)
    cut = moli.identify(*halves, nmax=NMAX, refine="path")
    assert cut.skipped == ("refinement of the path", "covariance", "noise model")
    assert [st.mean_vaf for st in cut.path] == [st.mean_vaf for st in unrefined.path]


def test_a_49_sample_record_warns_that_the_order_is_a_guess():
    with pytest.warns(moli.ShortValidationWarning, match="chosen on 15 validation samples"):
        result = moli.identify(moli.example_data(N=49, seed=1))
    assert "on 15 validation samples" in result.summary()


def test_a_long_enough_validation_part_does_not_warn(halves):
    est, val = halves
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = moli.identify(est, val, nmax=NMAX, refine="none", noise_model=False)
    assert selection_samples_needed(result.path, est.m) <= val.N   # 120 <= 200: the case under test
    assert not [w for w in caught if issubclass(w.category, moli.ShortValidationWarning)]


def test_samples_needed_is_ten_per_parameter_of_the_largest_model():
    # (2, 1, 1) with 3 inputs: output 1 has 2 * 3 past outputs and 2 * 3 past inputs = 12
    # parameters (moli.method.structure.rows.parameter_counts), the most of the path
    from types import SimpleNamespace
    path = [SimpleNamespace(indices=(1, 1, 1)), SimpleNamespace(indices=(2, 1, 1))]
    assert selection_samples_needed(path, 3) == SAMPLES_PER_PARAMETER * 12


def test_ctrl_c_in_the_refined_order_rule_falls_back_to_the_paired_rule(halves, monkeypatch):
    paired = moli.identify(*halves, nmax=NMAX, order_rule="paired", refine="none")
    monkeypatch.setattr(order_choice, "select_order_refined", interrupt)
    cut = moli.identify(*halves, nmax=NMAX, order_rule="refined")
    assert cut.skipped == ("order rule's refinements", "refinement", "covariance", "noise model")
    assert cut.selected.indices == paired.selected.indices
    assert cut.selection.startswith("lowest order within one paired standard error")


@settings(max_examples=200, deadline=None)
@given(N=st.integers(0, 3000), p=st.integers(1, 5), m=st.integers(0, 4), feedthrough=st.booleans())
def test_largest_order_is_the_last_balanced_list_the_samples_estimate(N, p, m, feedthrough):
    """By its definition: the balanced list (longer indices first) of that order fits in N
    samples and the next order's does not; p - 1 when not even order p fits."""
    def fits(n):
        q, r = divmod(n, p)
        return samples_needed((q + 1,) * r + (q,) * (p - r), m, feedthrough) <= N

    n = largest_order(N, p, m, feedthrough)
    assert n >= p - 1 and not fits(n + 1)
    assert n == p - 1 or fits(n)


def test_largest_order_of_a_long_record_is_found_at_once():
    """The 700000 estimation samples of a 10^6-sample record reach order 299997 with 3
    outputs and 3 inputs: found by bisection, not by stepping through every order (which
    took seconds on such records)."""
    q = 299997 // 3
    assert samples_needed((q, q, q), 3) <= 700000 < samples_needed((q + 1, q, q), 3)
    assert largest_order(700000, 3, 3) == 299997
