"""A chunk with one bad sample is refused whole: the estimator is left exactly as it was."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import moli
from moli import DataError, OptionError

INDICES = [2, 2, 2]
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)
RECORD = moli.example_data(N=200, seed=3)


def _nan_in_the_middle() -> tuple[np.ndarray, np.ndarray]:
    y = RECORD.y[100:150].copy()
    y[20, 1] = np.nan
    return y, RECORD.u[100:150]


BAD_CHUNKS = {
    "NaN in the middle": _nan_in_the_middle,
    "inf in the middle": lambda: (np.where(np.isnan(_nan_in_the_middle()[0]), np.inf, RECORD.y[100:150]),
                                  RECORD.u[100:150]),
    "too wide": lambda: (RECORD.y[100:150], np.ones((50, 4))),
    "lengths differ": lambda: (RECORD.y[100:150], RECORD.u[100:149]),
    "complex": lambda: (RECORD.y[100:150] * 1j, RECORD.u[100:150]),
    "text": lambda: ("abc", RECORD.u[100:150]),
}
ESTIMATORS = {
    "recursive": lambda: moli.RecursiveMoli(INDICES, ALPHA, 3),
    "chunked": lambda: moli.ChunkedEstimator(INDICES, ALPHA, 3),
    "filter bank": lambda: moli.FilterBank(INDICES, [(0.5, 0.7), (0.3, 0.7)], 3, retune_every=50, window=50),
}


def _absorb(estimator, y, u):
    return estimator.add(y, u) if isinstance(estimator, moli.ChunkedEstimator) else estimator.update_many(y, u)


@pytest.mark.parametrize("kind", sorted(ESTIMATORS))
@pytest.mark.parametrize("chunk", sorted(BAD_CHUNKS))
def test_a_bad_chunk_leaves_the_estimator_as_it_was(kind, chunk):
    estimator = ESTIMATORS[kind]()
    _absorb(estimator, RECORD.y[:100], RECORD.u[:100])
    before = pickle.dumps(estimator)  # every attribute, filter states and factors included
    y, u = BAD_CHUNKS[chunk]()
    y_given = np.array(y, copy=True)
    with pytest.raises(DataError):
        _absorb(estimator, y, u)
    assert pickle.dumps(estimator) == before
    assert np.array_equal(np.asarray(y), y_given, equal_nan=y_given.dtype.kind in "fc")
    # and the stream goes on as if the bad chunk had never come (same chunks: same round-off)
    clean = ESTIMATORS[kind]()
    _absorb(clean, RECORD.y[:100], RECORD.u[:100])
    _absorb(clean, RECORD.y[100:150], RECORD.u[100:150])
    _absorb(estimator, RECORD.y[100:150], RECORD.u[100:150])
    assert pickle.dumps(estimator) == pickle.dumps(clean)


@pytest.mark.parametrize("kwargs, message", [
    ({"m": "3"}, "m .* must be an integer"),
    ({"m": 0}, "m .* must be an integer of at least 1"),
    ({"Ts": "1"}, "Ts must be a positive finite number"),
    ({"Ts": float("nan")}, "Ts must be a positive finite number"),
])
def test_bad_settings_of_a_streaming_estimator(kwargs, message):
    settings = {"indices": INDICES, "alpha": ALPHA, "m": 3, **kwargs}
    for cls in (moli.RecursiveMoli, moli.ChunkedEstimator):
        with pytest.raises(OptionError, match=message):
            cls(**settings)


def test_a_filter_bank_refuses_a_text_grid():
    with pytest.raises(OptionError, match="omega must be an array of real"):
        moli.FilterBank(INDICES, "abc", 3)
