"""The block simulations against the plain per-sample recursion they replace."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from moli.models.simulation import free_response, simulate_batch, state_responses


def _stable(rng: np.random.Generator, n: int, radius: float) -> np.ndarray:
    A = rng.standard_normal((n, n))
    return A * radius / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-12)


def _recursion(A: np.ndarray, C: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``S[t] = C X_t`` with ``X_{t+1} = A X_t + v_t I``, ``X_0 = 0``, one sample at a time."""
    n = A.shape[0]
    X, out = np.zeros((n, n)), np.empty((v.size, C.shape[0], n))
    for t, value in enumerate(v):
        out[t] = C @ X
        X = A @ X + value * np.eye(n)
    return out


# N from below one block to several blocks with a partial last one (blocks of about sqrt(N)/2)
@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 6), p=st.integers(1, 3), k=st.integers(1, 3), N=st.integers(1, 400),
       seed=st.integers(0, 2**16))
def test_state_responses_are_the_recursion_of_each_signal_through_each_state(n, p, k, N, seed):
    rng = np.random.default_rng(seed)
    A, C, signals = _stable(rng, n, 0.95), rng.standard_normal((p, n)), rng.standard_normal((N, k))
    found = dict(state_responses(A, C, signals))
    assert sorted(found) == list(range(k))
    for c in range(k):
        expected = _recursion(A, C, signals[:, c])
        # the block form sums the same products in another order: round-off of the
        # responses' size, times the (at most N) terms of a stable model's sums
        scale = max(np.abs(expected).max(), 1.0)
        np.testing.assert_allclose(found[c], expected, rtol=0, atol=1e-12 * scale)


def test_state_responses_sum_to_the_simulation_of_the_input_matrix():
    # the response of u_c through B is sum_a B[a, c] times its response through state a
    rng = np.random.default_rng(3)
    n, p, m, N = 4, 2, 3, 1000
    A, B, C = _stable(rng, n, 0.9), rng.standard_normal((n, m)), rng.standard_normal((p, n))
    u = rng.standard_normal((N, m))
    total = sum(S @ B[:, c] for c, S in state_responses(A, C, u))
    simulated = simulate_batch(A[None], B[None], C[None], u)[0]
    # two block computations of one linear map: round-off of the outputs' size
    np.testing.assert_allclose(total, simulated, rtol=0, atol=1e-12 * np.abs(simulated).max())


def test_a_free_response_cut_where_it_decays_is_the_head_of_the_whole():
    rng = np.random.default_rng(5)
    A, C = _stable(rng, 4, 0.9), rng.standard_normal((2, 4))
    whole = free_response(A, C, 50000)
    cut = free_response(A, C, 50000, negligible=1e-17)
    # 0.9^4096 is far below 1e-17: the first length tried is kept
    assert cut.shape == (4096, 2, 4)
    # the same simulation, shorter (in blocks of another length: round-off of its size)
    np.testing.assert_allclose(cut, whole[:4096], rtol=0, atol=1e-12 * np.abs(whole).max())
    assert np.abs(whole[4096:]).max() <= 1e-17 * np.abs(whole).max()
    slow = _stable(rng, 4, 0.9999)                              # not decayed by 50000 samples
    assert free_response(slow, C, 50000, negligible=1e-17).shape[0] == 50000
