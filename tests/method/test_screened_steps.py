"""Screened greedy steps (``screen_lists``): the candidate lists ranked at the raised list's filter."""

import warnings

import numpy as np
import pytest

import moli
from moli.method.search import greedy_path as greedy
from moli.method.search.greedy_path import StructureSearch
from moli.method.structure.indices import raised
from moli.method.tuning.barycenter import default_omega

from systems_util import plant_record


@pytest.fixture(scope="module")
def records():
    est, val = moli.example_data(N=700, seed=3).split(450)
    est = est.remove_means()
    return est, val.remove_means(est.y_offset, est.u_offset)


def test_the_screened_list_has_the_lowest_j_at_the_filter(records):
    search = StructureSearch(*records, default_omega(1.0), tuning="grid", screen_lists=True)
    start = search.fit((2, 1, 1))
    lists = list(raised(start.indices))
    chosen = search.screened(lists, start.eta)
    # each list scored alone, by its own scorer, at that one filter
    alone = [StructureSearch(*records, default_omega(1.0), tuning="grid")._scorer(ix).score(start.eta[None])[0][0]
             for ix in lists]
    assert chosen == lists[int(np.argmin(alone))]


@pytest.fixture
def tuned(monkeypatch) -> list:
    """Every list the searches tune from here on, in order."""
    lists = []
    original = StructureSearch._tune

    def counting(self, candidates):
        lists.extend(candidates)
        return original(self, candidates)

    monkeypatch.setattr(StructureSearch, "_tune", counting)
    return lists


def test_a_screened_path_tunes_one_list_per_step(records, tuned):
    search = StructureSearch(*records, default_omega(1.0), tuning="grid", screen_lists=True)
    path = greedy.greedy_path(search, 7)
    assert [st.order for st in path] == [3, 4, 5, 6, 7]
    for before, after in zip(path, path[1:]):
        assert sorted(np.subtract(after.indices, before.indices)) == [0, 0, 1]
    # the first list, then one list per step where the unscreened path tunes all three candidates
    assert len(tuned) == len(path)


@pytest.mark.parametrize("seed", [0, 1])
def test_screened_identification_recovers_a_noise_free_plant(seed):
    y, u, (A, B, C) = plant_record(800, 0.0, seed)
    est, val = moli.IOData(y, u).split(500)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # no centring (the record's means are not the plant's operating point) and the
        # validation's initial state estimated: the least squares of the true list is then exact
        result = moli.identify(est, val, nmax=8, preset="fast", center=False, x0="estimate")
    assert result.model.n == 6
    w = np.linspace(0.01, np.pi, 100)
    truth = moli.StateSpaceModel(A, B, C).frequency_response(w)
    # exact recovery up to round-off (4e-15 seen): 1e-8 leaves room for any BLAS
    assert np.max(np.abs(result.model.frequency_response(w) - truth)) <= 1e-8 * np.max(np.abs(truth))


@pytest.mark.parametrize("refine_siblings", [True, False])
def test_the_sibling_lists_are_tuned_only_where_they_are_refined(records, tuned, refine_siblings):
    path = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(*records, nmax=7, preset="fast", refine_siblings=refine_siblings, noise_model=False,
                               progress=lambda step: path.append(step.indices))
    k = result.selected_index
    assert k > 0, "the record must select an order above the first, or there are no siblings"
    # the lists the greedy step screened at the selected order and did not take
    siblings = set(raised(path[k - 1])) - {path[k]}
    assert siblings
    assert siblings <= set(tuned) if refine_siblings else not siblings & set(tuned)
