"""The generic list judged at its early stop (``screen_generic``): only a list kept there is taken
on to its optimum."""

import warnings

import numpy as np
import pytest

import moli
from moli.method.refinement.refined_steps import RefinedSteps
from moli.method.structure.indices import generic_indices

POLISHED = RefinedSteps.polished


def identified(N, split, seed, monkeypatch, screen_generic):
    """The fast preset on the example plant, and the lists whose refinements were taken to their optimum."""
    est, val = moli.example_data(N=N, seed=seed).split(split)
    est = est.remove_means()
    val = val.remove_means(est.y_offset, est.u_offset)
    polished = []

    def counting(self, step):
        polished.append(step.indices)
        return POLISHED(self, step)

    monkeypatch.setattr(RefinedSteps, "polished", counting)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(est, val, nmax=7, preset="fast", screen_generic=screen_generic, noise_model=False)
    return result, polished


@pytest.mark.parametrize("seed", [1, 2])
def test_a_generic_list_kept_at_its_early_stop_is_the_model_the_unscreened_refinement_returns(seed, monkeypatch):
    screened, _ = identified(700, 450, seed, monkeypatch, True)
    unscreened, _ = identified(700, 450, seed, monkeypatch, False)
    generic = generic_indices(screened.model.n, 3)
    assert screened.model.indices == generic, "the record must keep the generic list, or the test proves nothing"
    # both take the same early-stopped refinement to the same optimum: the same arithmetic
    for name in ("A", "B", "C", "D"):
        assert np.array_equal(getattr(screened.model, name), getattr(unscreened.model, name))


@pytest.mark.parametrize("seed", [6, 15])
def test_a_generic_list_short_of_the_line_at_its_early_stop_is_not_taken_to_its_optimum(seed, monkeypatch):
    screened, polished = identified(400, 250, seed, monkeypatch, True)
    _, unscreened_polished = identified(400, 250, seed, monkeypatch, False)
    generic = generic_indices(screened.path[screened.selected_index].order, 3)
    assert screened.model.indices != generic
    assert generic in unscreened_polished, "the unscreened refinement polishes every generic list it tries"
    assert generic not in polished
