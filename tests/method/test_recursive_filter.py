"""recursive_filter against scipy.signal.lfilter, and an identification without scipy.signal or scipy.stats."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

import moli
from moli.numerics.recursive_filter import recursive_filter

SETTINGS = settings(deadline=None, derandomize=True, max_examples=80,
                    suppress_health_check=[HealthCheck.too_slow])


def _stable_denominator(roots: list[float]) -> np.ndarray:
    return np.poly(roots) if roots else np.array([1.0])


def _close(actual: np.ndarray, expected: np.ndarray) -> None:
    # Both run the same recursion with the sums in another order: each step's rounding
    # (a few eps) is amplified at most by the filter's gain sum |h| <= prod 1 / (1 - |p|),
    # under 10**4 for poles of modulus <= 0.9 and degree <= 4; 1e-10 of the signals'
    # scale leaves a margin of some 100 over that.
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-10 * scale)


roots = st.lists(st.floats(-0.9, 0.9), max_size=4)
numerators = st.lists(st.floats(-2, 2), min_size=1, max_size=5)


@SETTINGS
@given(roots=roots, b=numerators, samples=st.integers(1, 60), signals=st.integers(1, 3),
       axis=st.sampled_from([0, 1]), seed=st.integers(0, 2**16))
def test_matches_lfilter_from_rest_and_from_a_state(roots, b, samples, signals, axis, seed):
    a = _stable_denominator(roots)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((samples, signals) if axis == 0 else (signals, samples))
    before = x.copy()
    _close(recursive_filter(b, a, x, axis=axis), lfilter(b, a, x, axis=axis))
    order = max(len(a), len(b)) - 1
    zi = rng.standard_normal((order, signals) if axis == 0 else (signals, order))
    y, zf = recursive_filter(b, a, x, axis=axis, zi=zi)
    y_ref, zf_ref = lfilter(b, a, x, axis=axis, zi=zi)
    _close(y, y_ref)
    _close(zf, zf_ref)
    np.testing.assert_array_equal(x, before)   # the input is not overwritten


@SETTINGS
@given(roots=roots, b=numerators, cuts=st.lists(st.integers(0, 40), min_size=1, max_size=4),
       seed=st.integers(0, 2**16))
def test_chunks_chained_by_their_states_are_the_whole_record(roots, b, cuts, seed):
    """Chunks shorter than the order, and empty ones, included (the state then keeps part of
    the one before); the last chunk is the rest of the record, at least one sample."""
    a = _stable_denominator(roots)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((2, sum(cuts) + 1))
    zi = rng.standard_normal((2, max(len(a), len(b)) - 1))
    y_ref, zf_ref = lfilter(b, a, x, zi=zi)
    state, pieces, start = zi, [], 0
    for length in [*cuts, 1]:
        piece, state = recursive_filter(b, a, x[:, start : start + length], zi=state)
        pieces.append(piece)
        start += length
    _close(np.concatenate(pieces, axis=1), y_ref)
    _close(state, zf_ref)


@pytest.mark.parametrize("shape, axis", [((3, 50, 2), 1), ((50,), 0), ((4, 2, 30), -1)])
def test_any_axis_of_any_rank(shape, axis):
    a, b = np.poly([0.8, -0.5, 0.3]), [0.5, 1.0]
    x = np.random.default_rng(0).standard_normal(shape)
    zi_shape = list(shape)
    zi_shape[axis] = 3
    zi = np.random.default_rng(1).standard_normal(zi_shape)
    y, zf = recursive_filter(b, a, x, axis=axis, zi=zi)
    y_ref, zf_ref = lfilter(b, a, x, axis=axis, zi=zi)
    _close(y, y_ref)
    _close(zf, zf_ref)


def test_a_denominator_not_monic_is_scaled_as_lfilter_does():
    x = np.random.default_rng(2).standard_normal(40)
    _close(recursive_filter([2.0, 1.0], [2.0, -1.2, 0.5], x), lfilter([2.0, 1.0], [2.0, -1.2, 0.5], x))


def test_no_samples_keep_the_state():
    zi = np.array([[1.0, 2.0], [3.0, 4.0]])
    y, zf = recursive_filter([1.0], [1.0, -0.5, 0.1], np.zeros((0, 2)), axis=0, zi=zi)
    assert y.shape == (0, 2)
    np.testing.assert_array_equal(zf, zi)


def test_an_identification_in_a_fresh_process_imports_neither_scipy_signal_nor_scipy_stats():
    """Each costs most of a second to import, which a first identification paid."""
    code = ("import sys, warnings; warnings.simplefilter('ignore'); import moli; "
            "moli.identify(moli.example_data(N=300)); "
            "moli.empirical_frequency_response(moli.example_data(N=300)); "
            "print(sorted(name for name in ('scipy.signal', 'scipy.stats') if name in sys.modules))")
    source = str(Path(moli.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=source + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
