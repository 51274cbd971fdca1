import warnings
from math import comb

import numpy as np
import pytest

import moli
from moli.method.selection.order_rules import select_order
from moli.method.search.greedy_path import PathStep, StructureSearch, exhaustive, greedy_path
from moli.method.tuning.barycenter import default_omega


@pytest.fixture(scope="module")
def search():
    est, val = moli.example_data(N=700, seed=3).split(450)
    est = est.remove_means()
    val = val.remove_means(est.y_offset, est.u_offset)
    return StructureSearch(est, val, default_omega(1.0), tuning="grid")


def test_greedy_path_raises_one_index_per_step(search):
    path = greedy_path(search, 7)
    assert path[0].indices == (1, 1, 1)
    assert [st.order for st in path] == [3, 4, 5, 6, 7]
    for before, after in zip(path, path[1:]):
        diff = np.subtract(after.indices, before.indices)
        assert sorted(diff) == [0, 0, 1]
        # the kept list has the lowest J of the p candidates
        rivals = [search.fit(c) for c in moli.method.structure.indices.raised(before.indices)]
        assert after.J == min(r.J for r in rivals)


def test_exhaustive_fits_every_list(search):
    steps = exhaustive(search, 5)
    assert len(steps) == comb(4, 2)
    assert {st.indices for st in steps} == set(moli.method.structure.indices.compositions(5, 3))


def _step(order, mean_vaf, stable=True):
    A = [[0.5]] if stable else [[1.5]]
    model = moli.StateSpaceModel(A, [[1.0]], [[1.0]])
    return PathStep((order,), order, 0.1, 0.1, np.array([1.0, 1.0]), np.array([mean_vaf]), model, 0.0)


def test_order_rule_lowest_within_one_point():
    path = [_step(3, 70.0), _step(4, 80.5), _step(5, 81.2), _step(6, 81.0)]
    assert select_order(path) == 1  # 80.5 is within 1 point of 81.2
    assert select_order(path, tolerance=0.1) == 2
    # an unstable model is never chosen while a stable one exists
    path[2] = _step(5, 90.0, stable=False)
    assert select_order(path) == 1


def test_identify_recovers_example_plant():
    est, val = moli.example_data(N=1000, noise=0.1, seed=0).split(600)
    result = moli.identify(est, val, nmax=8, tuning="grid")
    # 10 % output noise caps the VAF at ~99 %; 4 points of margin for estimation error
    assert result.selected.mean_vaf > 95.0
    assert result.model is result.selected.model
    assert result.model.is_stable()
    assert "selected" in result.summary()
    np.testing.assert_allclose(result.model.u_offset, est.u.mean(axis=0))


def test_identify_is_reproducible_and_seeded():
    data = moli.example_data(N=500, seed=4)
    first = moli.identify(data, nmax=5, seed=7)
    again = moli.identify(data, nmax=5, seed=7)
    np.testing.assert_array_equal(first.model.A, again.model.A)
    assert [st.indices for st in first.path] == [st.indices for st in again.path]


def test_identify_holds_out_tail_without_validation():
    data = moli.example_data(N=500, seed=5)
    result = moli.identify(data, nmax=4, tuning="grid")
    assert "held out" in result.validation_source
    assert (result.estimation.N, result.validation.N) == (350, 150)


def test_identify_rejects_bad_options():
    data = moli.example_data(N=300)
    with pytest.raises(moli.OptionError, match="unknown option"):
        moli.identify(data, n_max=4)
    with pytest.raises(moli.OptionError, match="tuning"):
        moli.identify(data, tuning="newton")
    with pytest.raises(moli.OptionError, match="nmax"):
        moli.identify(data, nmax=2)
    with pytest.raises(moli.OptionError, match="omega"):
        moli.identify(data, omega=[[0.1, -1.0]])
    with pytest.raises(moli.DataError, match="too few samples"):
        moli.identify(data[:8], validation=data[8:40])


def test_a_fixed_order_selects_that_model_of_the_path():
    est, val = moli.example_data(N=500, seed=4).split(330)
    free = moli.identify(est, val, nmax=5)
    fixed = moli.identify(est, val, order=5)  # the path runs to the fixed order
    assert fixed.nmax == 5 and fixed.selected.order == 5
    assert [st.indices for st in fixed.path] == [st.indices for st in free.path]
    np.testing.assert_array_equal(fixed.model.A, free.path[-1].model.A)
    assert "the fixed order n = 5 (IdentifyOptions.order)" in fixed.summary()
    with pytest.raises(moli.OptionError, match="order must be at least the number of outputs, 3"):
        moli.identify(est, val, order=2)
    # 20 samples carry lists up to n = 6 only: said before the search
    with pytest.raises(moli.DataError, match="order = 9 .* the largest order is 6"):
        moli.identify(est[:20], val, order=9)


def test_records_of_different_periods_are_refused():
    est, val = moli.example_data(N=400, seed=4).split(300)
    slow = moli.IOData(val.y, val.u, Ts=2.0)
    with pytest.raises(moli.DataError, match="validation is sampled every Ts = 2, data every Ts = 1"):
        moli.identify(est, slow, nmax=3)
    model = moli.identify(est, val, nmax=3).model
    with pytest.raises(moli.DataError, match="record is sampled every Ts = 2, the model every Ts = 1"):
        moli.compare(model, slow)
    # a period written with fewer digits is the same period (relative 1e-6)
    assert moli.compare(model, moli.IOData(val.y, val.u, Ts=1 + 1e-9)).vaf.shape == (3,)


def test_unstable_plant_warns_and_does_not_crash():
    rng = np.random.default_rng(8)
    u = rng.standard_normal((300, 1))
    y = np.zeros((300, 1))
    for k in range(1, 300):
        y[k] = 1.02 * y[k - 1] + u[k - 1]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = moli.identify(moli.IOData(y, u), nmax=3, tuning="grid", center=False)
    assert len(result.path) == 3
    assert any(issubclass(w.category, moli.UnstableModelWarning) for w in caught)


def test_paired_order_rule_reaches_the_true_order_on_long_records():
    # 3x3 plant of order 6 with 10 % output noise: on a long validation record the
    # paired standard error is small, so the rule keeps the order the data support;
    # on a short one it settles lower, never above the best model's order
    long_est, long_val = moli.example_data(N=6000, seed=11).split(3000)
    long = moli.identify(long_est, long_val, nmax=8, order_rule="paired")
    best = max(range(len(long.path)), key=lambda i: long.path[i].mean_vaf)
    assert long.selected.order >= 6 and long.selected.order <= long.path[best].order
    short_est, short_val = moli.example_data(N=300, seed=11).split(200)
    short = moli.identify(short_est, short_val, nmax=8, order_rule="paired")
    best = max(range(len(short.path)), key=lambda i: short.path[i].mean_vaf)
    assert short.selected.order <= short.path[best].order


def test_paired_order_rule_is_the_best_model_when_nothing_ties():
    from moli.method.selection.order_rules import select_order_paired

    est, val = moli.example_data(N=800, seed=3).split(500)
    result = moli.identify(est, val, nmax=6)
    val_c = val.remove_means(result.estimation.y_offset, result.estimation.u_offset)
    chosen = select_order_paired(result.path, val_c, z=0.0)  # no tolerance: the best stable model
    stable = [i for i, st in enumerate(result.path) if st.stable]
    assert chosen == max(stable, key=lambda i: result.path[i].mean_vaf)


def _scored_step(model, order, validation):
    from moli.validation.comparison import compare
    return PathStep((order,), order, 0.1, 0.1, np.array([1.0, 1.0]), compare(model, validation).vaf, model, 0.0)


def test_a_bound_order_warns_only_where_it_clearly_beats_the_lower_ones():
    from moli.method.selection.checks import warn_if_at_bound

    # a lightly damped second-order plant seen through 5 % output noise
    rng = np.random.default_rng(0)
    true = moli.StateSpaceModel([[1.6, -0.8], [1.0, 0.0]], [[1.0], [0.0]], [[0.1, 0.05]])
    u = rng.standard_normal((2000, 1))
    y = true.simulate(u)
    validation = moli.IOData(y + 0.05 * y.std() * rng.standard_normal(y.shape), u)
    first_order = moli.StateSpaceModel([[0.9]], [[1.0]], [[0.1]])
    # the order-2 model at the bound nmax = 2 fits far better than order 1: a higher order
    # may fit better still, and the run says so
    with pytest.warns(moli.OrderBoundWarning, match="nmax = 2"):
        warn_if_at_bound([_scored_step(first_order, 1, validation), _scored_step(true, 2, validation)], 1, 2,
                         validation)
    # the same model at both orders (a state that changes nothing): whatever its score says
    # by a hair, the bound order does not beat the lower one, and nothing is said
    lower, bound = _scored_step(true, 1, validation), _scored_step(true, 2, validation)
    bound = PathStep(bound.indices, 2, 0.1, 0.1, bound.eta, bound.vaf + 0.05, true, 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", moli.OrderBoundWarning)
        warn_if_at_bound([lower, bound], 1, 2, validation)
        # below the bound there is nothing to say either
        warn_if_at_bound([_scored_step(first_order, 1, validation), _scored_step(true, 2, validation)], 1, 3,
                         validation)


def _noisy_record(A, B, C, seed, N=600, noise=0.1):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, 1))
    y = moli.StateSpaceModel(A, B, C).simulate(u)
    return moli.IOData(y + noise * y.std() * rng.standard_normal(y.shape), u)


@pytest.mark.parametrize("seed", range(3))
def test_a_bound_order_warns_only_where_the_next_order_fits_clearly_better(seed):
    # at nmax = 1 a SISO path has no lower order to beat, so the lower orders say nothing:
    # the path's next step (order 2) is what says whether a higher order fits better
    def bound_warned(A, B, C):
        est, val = _noisy_record(A, B, C, seed).split(400)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            moli.identify(est, val, nmax=1)
        return any(issubclass(w.category, moli.OrderBoundWarning) for w in caught)

    # a first-order plant: order 2 fits no better, and nothing is said (it always was before)
    assert not bound_warned([[0.8]], [[1.0]], [[0.5]])
    # the lightly damped second-order plant: order 2 fits far better, and the run says so
    assert bound_warned([[1.6, -0.8], [1.0, 0.0]], [[1.0], [0.0]], [[0.1, 0.05]])


@pytest.mark.parametrize("seed", range(2))
def test_the_next_order_is_judged_on_the_record_it_was_fitted_on(seed):
    # with an input delay the search fits and scores its lists on the inputs shifted by it;
    # the bound's next order must be judged there too (on the unshifted record the two
    # least-squares models are simulated out of step with the data, and nothing was said)
    est, val = _noisy_record([[1.6, -0.8], [1.0, 0.0]], [[1.0], [0.0]], [[0.1, 0.05]], seed).split(400)
    shift = 4
    # the inputs as logged 4 samples before they reach the plant
    delayed_est = moli.IOData(est.y[:-shift], est.u[shift:])
    delayed_val = moli.IOData(val.y[:-shift], val.u[shift:])
    with pytest.warns(moli.OrderBoundWarning, match="order 2 fits it clearly better still"):
        moli.identify(delayed_est, delayed_val, nmax=1, delays=shift)


def _fit_warnings(data, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = moli.identify(data, **options)
    return result, [w for w in caught if issubclass(w.category, moli.NoFitWarning)]


def test_a_model_of_noise_says_it_fits_no_output():
    # outputs independent of the inputs: no order can beat the outputs' means on fresh samples,
    # yet the path still "selects" an order (49 rows, the record of the failure reported)
    rng = np.random.default_rng(0)
    _, found = _fit_warnings(moli.IOData(rng.standard_normal((49, 2)), rng.standard_normal((49, 2))))
    assert len(found) == 1 and "every output (y1, y2)" in str(found[0].message)
    assert found[0].filename == __file__            # it points at the caller of identify


def test_only_the_output_that_is_noise_is_named():
    # y1 follows the example plant, y2 is noise of its own: y2 alone is named
    data = moli.example_data(N=600, seed=2)
    rng = np.random.default_rng(5)
    mixed = moli.IOData(np.column_stack([data.y[:, 0], rng.standard_normal(600)]), data.u)
    result, found = _fit_warnings(mixed, nmax=6)
    assert len(found) == 1 and "output y2 no better than its mean" in str(found[0].message)
    assert result.selected.vaf[0] > 50


def test_a_model_that_fits_gets_no_such_warning():
    _, found = _fit_warnings(moli.example_data(N=600, seed=2), nmax=6)
    assert found == []
