"""Random binary excitation: levels, reproducibility, switching statistics."""

from __future__ import annotations

import numpy as np
import pytest

from moli.data.signals import SignalError, dwell_times, random_binary_signal


def test_levels_shape_and_seed():
    levels = [[0.3, 0.8], [-0.2, -0.1]]
    u = random_binary_signal(600, 8.0, 0.1, levels, seed=3)
    assert u.shape == (600, 2)
    np.testing.assert_array_equal(np.unique(u[:, 0]), [0.3, 0.8])
    np.testing.assert_array_equal(np.unique(u[:, 1]), [-0.2, -0.1])
    np.testing.assert_array_equal(u, random_binary_signal(600, 8.0, 0.1, levels, seed=3))
    assert not np.array_equal(u, random_binary_signal(600, 8.0, 0.1, levels, seed=4))


def test_switching_statistics_match_the_mean_switching_time():
    Ts, mean_time, N = 0.1, 8.0, 200_000
    u = random_binary_signal(N, mean_time, Ts, seed=11)[:, 0]
    p = Ts / mean_time
    switches = np.count_nonzero(np.diff(u))
    # Switch count ~ Binomial(N-1, p): mean 2500, sd 50; 5 sd cannot fail by chance
    # (probability < 1e-6) yet catches a wrong p by 10 %.
    sd = np.sqrt(N * p * (1 - p))
    assert abs(switches - N * p) < 5 * sd
    dwell = dwell_times(u) * Ts
    # Geometric dwell times: mean 8 s, sd ~ 8 s; the sample mean of ~2500 has sd 0.16 s.
    assert abs(dwell.mean() - mean_time) < 5 * mean_time / np.sqrt(dwell.size)
    # Memorylessness: P(dwell > 8 s) = (1 - p)^80 = 0.367; binomial sd ~ 0.01.
    tail = np.mean(dwell > mean_time + 1e-9)
    assert abs(tail - (1 - p) ** 80) < 5 * np.sqrt(0.367 * 0.633 / dwell.size)


def test_channels_are_independent():
    u = random_binary_signal(100_000, 8.0, 0.1, seed=2, levels=[[-1, 1], [-1, 1]])
    # Correlation of two independent telegraph signals: sd ~ sqrt(2 * 80 / N) = 0.04
    # (80-sample correlation time); 0.2 is 5 sd.
    assert abs(np.corrcoef(u.T)[0, 1]) < 0.2


def test_switch_within_guarantees_a_switch_in_the_window():
    for seed in range(20):
        u = random_binary_signal(600, 8.0, 0.1, seed=seed, levels=[[0, 1], [0, 1]], switch_within=150)
        assert np.all(np.any(np.diff(u[:150], axis=0) != 0, axis=0)), seed


def test_bad_arguments_raise_value_errors():
    with pytest.raises(SignalError):
        random_binary_signal(0, 8.0)
    with pytest.raises(ValueError, match="mean_switch_time"):
        random_binary_signal(10, 0.05, Ts=0.1)
    with pytest.raises(SignalError, match="levels"):
        random_binary_signal(10, 8.0, levels=[1.0, 2.0, 3.0])
    with pytest.raises(SignalError, match="did not switch"):
        random_binary_signal(10, 1e6, switch_within=5, max_draws=3)
