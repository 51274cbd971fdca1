"""Online filter tuning: the bank equals independent recursive estimators; retuning moves slot 0."""

import numpy as np
import pytest

import moli
from moli.errors import OptionError
from moli.streaming.filter_bank import FilterBank
from moli.method.structure.filters import filter_polynomial
from moli.streaming.recursive import RecursiveMoli
from moli.models.simulation import simulate_batch
from moli.method.tuning.barycenter import barycenter, grid

from systems_util import plant_record

INDICES = (2, 2, 2)
OMEGA = grid([0.2, 0.5, 1.0], [0.7, 1.1])


def record(N, seed=4):
    return plant_record(N, 0.05, seed)[:2]


def alone(eta, y, u):
    """The same candidate estimated on its own by RecursiveMoli."""
    return RecursiveMoli(INDICES, filter_polynomial(eta[0], eta[1], INDICES), 3).update_many(y, u).model


def test_bank_candidates_equal_separate_estimators_until_the_first_retune():
    y, u = record(600)
    bank = FilterBank(INDICES, OMEGA, 3, retune_every=1000, window=300).update_many(y, u)
    A, B, C = bank._bank.matrices()
    for r, eta in enumerate(bank.etas):
        expected = alone(eta, y, u).markov(20)
        got = moli.StateSpaceModel(A[r], B[r], C[r]).markov(20)
        # Same rows and algebra, batched instead of alone: round-off only.
        assert np.max(np.abs(got - expected)) < 1e-9


def test_retune_scores_window_and_moves_slot_zero_to_the_barycenter():
    y, u = record(400)
    bank = FilterBank(INDICES, OMEGA, 3, retune_every=400, window=300, burn_in=50)
    start = bank.etas.copy()
    bank.update_many(y[:399], u[:399])
    assert np.all(np.isnan(bank.costs))  # no scoring before retune_every samples
    bank.update(y[399], u[399])
    # Independent J (docs/method.md §5) of the models scored: slots 1.. are unchanged by the
    # retune; slot 0's scored model is rebuilt alone at its starting place.
    A, B, C = bank._bank.matrices()
    first = alone(start[0], y, u)
    A[0], B[0], C[0] = first.A, first.B, first.C
    yw, uw = y[100:], u[100:]
    yhat = simulate_batch(A, B, C, uw)[:, 50:]
    ratio = np.var(yw[None, 50:] - yhat, axis=1) / np.var(yw[50:], axis=0)
    J = np.minimum(ratio, 1.0).mean(axis=1)
    # same models and formula; differences are round-off in the simulation
    assert np.allclose(bank.costs, J, rtol=1e-8)
    assert np.allclose(bank.etas[1:], start[1:])  # the grid stays
    assert np.allclose(bank.etas[0], barycenter(start, J), rtol=1e-8)
    # slot 0 restarts from the prior on the window: equal to an estimator run on it alone
    A, B, C = bank._bank.matrices()
    got = moli.StateSpaceModel(A[0], B[0], C[0]).markov(20)
    assert np.max(np.abs(got - alone(bank.etas[0], yw, uw).markov(20))) < 1e-9
    assert bank.costs[bank.best] == bank.costs.min()


def test_chunking_does_not_change_the_bank():
    y, u = record(1000)
    whole = FilterBank(INDICES, OMEGA, 3, retune_every=300, window=250).update_many(y, u)
    pieces = FilterBank(INDICES, OMEGA, 3, retune_every=300, window=250)
    for a, b in [(0, 7), (7, 299), (299, 301), (301, 950)]:
        pieces.update_many(y[a:b], u[a:b])
    for k in range(950, 1000):
        pieces.update(y[k], u[k])
    assert np.allclose(whole.etas, pieces.etas, rtol=1e-9)
    assert np.allclose(whole.model.markov(10), pieces.model.markov(10), rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize(
    "kwargs",
    [{"retune_every": 0}, {"window": 1}, {"burn_in": 999}, {"forgetting": 1.2}, {"retune_every": 2.5}],
)
def test_bad_options_raise(kwargs):
    with pytest.raises(OptionError):
        FilterBank(INDICES, OMEGA, 3, **kwargs)
    with pytest.raises(OptionError):
        FilterBank(INDICES, [[0.1, -1.0]], 3)
