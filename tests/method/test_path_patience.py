"""The greedy path's early stop (``path_patience``): the path ends once that many orders in a row
have not raised the best validation fit of its eligible steps by more than the order tolerance."""

import warnings
from dataclasses import dataclass

import pytest

import moli
from moli.method.search.greedy_path import StructureSearch, best_eligible, greedy_path
from moli.method.tuning.barycenter import default_omega


@dataclass
class Scored:
    mean_vaf: float
    stable: bool


def best_of(steps):
    """The order rules' best eligible step, by their own definition: the stable steps (all where
    none is), the highest mean VAF, the first of equal ones."""
    eligible = [i for i, st in enumerate(steps) if st.stable] or list(range(len(steps)))
    return max(eligible, key=lambda i: (steps[i].mean_vaf, -i))


@pytest.mark.parametrize("steps", [
    [Scored(50, True), Scored(60, True), Scored(60, True), Scored(59, True)],     # a tie is no raise
    [Scored(50, False), Scored(40, True), Scored(90, False), Scored(45, True)],   # only stable ones count
    [Scored(70, False), Scored(80, False), Scored(75, False)],                    # none stable: all count
    [Scored(70, True), Scored(20, False), Scored(71, True)],
])
def test_the_running_best_is_the_order_rules_best_eligible_step(steps):
    best = 0
    for k in range(1, len(steps)):
        best = best_eligible(steps[: k + 1], best)
        assert best == best_of(steps[: k + 1])


@pytest.mark.parametrize("vafs, bests", [
    # raises of 0.05 and 0.08 do not count; 60.12 does: 0.12 over the best held, though 0.04 over the step before
    ([50, 60, 60.05, 60.08, 60.12, 59], [1, 1, 1, 4, 4]),
    ([70, 70.1, 70.3, 70.35], [0, 2, 2]),
])
def test_a_raise_within_the_margin_leaves_the_best_where_it_is(vafs, bests):
    steps = [Scored(v, True) for v in vafs]
    best = 0
    for k, expected in enumerate(bests, start=1):
        best = best_eligible(steps[: k + 1], best, margin=0.1)
        assert best == expected


@pytest.fixture(scope="module")
def records():
    est, val = moli.example_data(N=600, seed=3).split(400)
    est = est.remove_means()
    return est, val.remove_means(est.y_offset, est.u_offset)


@pytest.mark.parametrize("patience", [1, 2, 3])
def test_the_early_stop_cuts_the_full_path_where_the_rule_says(records, patience):
    nmax = 12
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        full = greedy_path(StructureSearch(*records, default_omega(1.0, "paper"), "grid", screen_lists=True), nmax)
        cut = greedy_path(StructureSearch(*records, default_omega(1.0, "paper"), "grid", screen_lists=True), nmax,
                          patience=patience)
    # the first step whose best eligible step lies `patience` steps back ends the path
    stop = next((k for k in range(len(full)) if k - best_of(full[: k + 1]) >= patience), len(full) - 1)
    assert stop < len(full) - 1, "the record must let the rule stop before nmax, or the test proves nothing"
    assert len(cut) == stop + 1
    # the early stop only ends the path: every step it keeps is the full path's
    for kept, step in zip(cut, full):
        assert kept.indices == step.indices
        assert kept.mean_vaf == step.mean_vaf


def test_a_fixed_order_is_reached_whatever_the_patience(records):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(*records, order=9, preset="fast", path_patience=1, refine="none", noise_model=False)
    assert result.model.n == 9
    assert [st.order for st in result.path] == list(range(3, 10))


def test_the_fast_preset_stops_its_path_and_the_default_does_not(records):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = moli.identify(*records, nmax=12, preset="fast", refine="none", noise_model=False)
        default = moli.identify(*records, nmax=12, screen_lists=True, refine="none", noise_model=False)
    assert fast.options.path_patience == 3 and default.options.path_patience is None
    assert default.path[-1].order == 12
    # the best by the order tolerance (0.1 point): a step counts where it raises the best held by more
    best = 0
    for k, step in enumerate(fast.path):
        if step.mean_vaf > fast.path[best].mean_vaf + fast.options.order_tolerance:
            best = k
    assert all(step.stable for step in fast.path)
    assert len(fast.path) - 1 - best == 3
    assert len(fast.path) < len(default.path)


@pytest.mark.parametrize("option", [{"path_patience": 3}, {"refine_siblings": False}, {"screen_generic": True}])
def test_the_fast_presets_search_options_are_refused_in_continuous_time(records, option):
    # continuous time has its own search and no refinement: the option would be silently ignored
    with pytest.raises(moli.OptionError, match=next(iter(option))):
        moli.identify(*records, time="continuous", **option)
