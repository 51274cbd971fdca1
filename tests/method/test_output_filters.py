"""Per-output filters: exactness, agreement with a direct fit, never worse on J, plumbing."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import moli
from moli.errors import DataError
from moli.method.least_squares.estimation import fit_batch
from moli.method.structure.filters import filter_divisors
from moli.method.tuning.output_filters import tune_output_cutoffs
from moli.method.refinement.observer_form import observer_form
from moli.method.refinement.levenberg_marquardt import refine
from moli.method.least_squares.shared_factors import RegressionCache
from moli.method.tuning.criterion import FilterScorer
from moli.method.tuning.barycenter import default_omega, tune_filter


def _slow_and_fast(seed: int, N: int = 600, noise: float = 0.2) -> np.ndarray:
    """Centred ``[y, u]`` of two decoupled outputs, one slow (pole 0.97) and one fast (0.4),
    with white noise and a random-walk drift on the outputs."""
    rng = np.random.default_rng(seed)
    plant = moli.StateSpaceModel(np.diag([0.97, 0.4]), [[0.03, 0.01], [0.5, 0.6]], np.eye(2))
    u = rng.standard_normal((N, 2))
    y = plant.simulate(u)
    scale = y.std(axis=0)
    y = y + 0.03 * scale * np.cumsum(rng.standard_normal(y.shape), axis=0)
    y = y + noise * scale * rng.standard_normal(y.shape)
    return np.column_stack([y - y.mean(axis=0), u - u.mean(axis=0)])


def _tuned(z: np.ndarray, feedthrough=False):
    scorer = FilterScorer(z, (1, 1), 1.0, 2.0, RegressionCache(z, 2, feedthrough))
    shared = tune_filter(scorer, default_omega(), "grid")
    return scorer, shared, tune_output_cutoffs(scorer, shared.eta, default_omega())


def test_divisors_of_unrelated_filters_recover_the_plant_exactly():
    # Output j's regression involves only its own divisor, so divisors that share no
    # root still give the exact model on noise-free data (docs/method.md §4's check)
    rng = np.random.default_rng(0)
    A = np.array([[0.9, 0.2, 0.0], [-0.2, 0.9, 0.1], [0.0, 0.0, 0.6]])
    B, C = rng.standard_normal((3, 2)), rng.standard_normal((2, 3))
    plant = moli.StateSpaceModel(A, B, C)
    u = rng.standard_normal((400, 2))
    z = np.column_stack([plant.simulate(u), u])
    first = np.poly([0.5 + 0.3j, 0.5 - 0.3j])          # output 1, index 2
    second = np.poly([-0.7])                          # output 2, index 1: not a root of the first
    A_hat, B_hat, C_hat, _ = fit_batch(z, (2, 1), [[first, second]])
    model = moli.StateSpaceModel(A_hat[0], B_hat[0], C_hat[0], indices=(2, 1), divisors=[first, second])
    # round-off of a least-squares fit on 400 samples of unit-scale signals
    np.testing.assert_allclose(model.markov(12), plant.markov(12), atol=1e-9)
    form = observer_form(model)
    np.testing.assert_allclose(form.matrices()[0], model.A, atol=1e-12)
    np.testing.assert_allclose(np.poly(form.A_D[:2, :2]), first, atol=1e-12)


def test_slow_and_fast_outputs_get_their_own_cutoffs():
    scorer, shared, found = _tuned(_slow_and_fast(0))
    assert found.J < shared.J
    slow, fast = found.etas[:, 0]
    assert slow < fast                          # the slow output's filter is the slower one
    # the same model by the direct route (filter each output by its own divisor, lstsq):
    # agreement to round-off shows the cached solutions were mixed correctly (and that
    # the direct route filters two outputs of equal index by their own divisors)
    A, B, C, _ = fit_batch(scorer.z, scorer.indices, [found.divisors])
    for mine, direct in zip(found.matrices, (A[0], B[0], C[0])):
        np.testing.assert_allclose(mine, direct, rtol=1e-8, atol=1e-10)
    assert scorer.criterion((A, B, C))[0] == pytest.approx(found.J, rel=1e-9)


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), feedthrough=st.sampled_from([False, "auto"]))
def test_never_worse_than_the_shared_filter_and_reports_its_own_j(seed, feedthrough):
    scorer, shared, found = _tuned(_slow_and_fast(seed, N=300), feedthrough)
    assert found.J <= found.J_shared
    assert found.J_shared == pytest.approx(shared.J, rel=1e-9)
    assert scorer.criterion(tuple(M[None] for M in found.matrices))[0] == pytest.approx(found.J, rel=1e-9)
    for divisor, (wc, zeta), l in zip(found.divisors, found.etas, scorer.indices):
        expected = filter_divisors(wc, zeta, scorer.indices, 1.0, 2.0)[scorer.indices.index(l)]
        np.testing.assert_allclose(divisor, expected, rtol=1e-12)


def test_identify_keeps_the_path_and_lowers_j_per_step():
    est, val = moli.example_data(N=700, seed=5).split(450)
    shared = moli.identify(est, val, nmax=6, output_filters=False)
    separate = moli.identify(est, val, nmax=6)
    assert separate.options.output_filters is True
    # the greedy path compares lists with the shared filter, so it is the same path
    assert [s.indices for s in separate.path] == [s.indices for s in shared.path]
    changed = 0
    for a, b in zip(shared.path, separate.path):
        assert b.J <= a.J
        if b.output_etas is not None:
            changed += 1
            assert b.model.divisors is not None and b.model.alpha is None
            assert [d.size - 1 for d in b.model.divisors] == list(b.indices)
    assert changed > 0
    # the summary lists per-output filters exactly when the selected model has them
    assert ("its filters per output" in separate.summary()) == (separate.selected.output_etas is not None)


def test_a_separate_filter_model_saves_loads_and_refines(tmp_path):
    data = moli.IOData(_slow_and_fast(1)[:, :2], _slow_and_fast(1)[:, 2:])
    est, val = data.split(400)
    result = moli.identify(est, val, nmax=4)
    step = next(s for s in result.path if s.output_etas is not None)
    step.model.save(tmp_path / "m.json")
    loaded = moli.load_model(tmp_path / "m.json")
    for a, b in zip(loaded.divisors, step.model.divisors):
        np.testing.assert_array_equal(a, b)
    refined = refine(step.model, result.estimation, iterations=3)
    assert refined.cost <= refined.cost_start
    assert all(np.array_equal(a, b) for a, b in zip(refined.model.divisors, step.model.divisors))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"divisors": [[1.0, -0.5]]}, "need the model's indices"),
        ({"indices": (1,), "divisors": [[1.0, -0.5, 0.06]]}, "degree 1"),
        ({"indices": (1,), "divisors": [[1.0, -1.5]]}, "stable"),
        ({"indices": (1,), "divisors": [[1.0, -0.5], [1.0, -0.2]]}, "one divisor per output"),
    ],
)
def test_bad_divisors_are_refused(kwargs, message):
    with pytest.raises(DataError, match=message):
        moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], **kwargs)
