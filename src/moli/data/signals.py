"""Excitation signals for identification experiments."""

from __future__ import annotations

import numpy as np

from ..errors import MoliError
from .arguments import integer, real_array, real_number

__all__ = ["SignalError", "random_binary_signal", "dwell_times"]


class SignalError(MoliError):
    """Invalid settings for an excitation signal."""


def random_binary_signal(
    N: int,
    mean_switch_time: float,
    Ts: float = 1.0,
    levels: object = (-1.0, 1.0),
    seed: int = 0,
    switch_within: int | None = None,
    *,
    max_draws: int = 1000,
) -> np.ndarray:
    """Random binary ("telegraph") signals with a given mean time between switches.

    Each channel holds one of its two levels and, at every sample, switches to the
    other with probability ``p = Ts / mean_switch_time``, independently of the past.
    Dwell times are therefore geometric with mean ``mean_switch_time`` (in the units
    of ``Ts``), the channels are independent, and the starting levels are drawn at
    random.

    Parameters
    ----------
    N : int
        Number of samples.
    mean_switch_time : float
        Mean time between switches, at least ``Ts`` (the CDC 2015 twin rotor
        experiment used 8 s with ``Ts = 0.1`` s).
    Ts : float, default 1.0
        Sampling period.
    levels : array_like, shape (2,) or (channels, 2), default (-1, 1)
        The two levels; one row per channel for several channels.
    seed : int, default 0
        Seed of the generator (same seed, same signal).
    switch_within : int, optional
        If given, redraw a channel until it switches at least once in its first
        ``switch_within`` samples (so a short estimation window sees both levels).
        The redraws come from the same seeded generator, so results stay reproducible.
    max_draws : int, default 1000
        Redraws allowed per channel before giving up.

    Returns
    -------
    ndarray, shape (N, channels)
        Time along axis 0.

    Raises
    ------
    SignalError
        On invalid sizes or times, or when ``switch_within`` cannot be met.

    Examples
    --------
    >>> u = random_binary_signal(600, 8.0, Ts=0.1, levels=[[0.3, 0.8], [-0.2, -0.1]], seed=1)
    >>> u.shape
    (600, 2)
    >>> np.unique(u[:, 0])
    array([0.3, 0.8])
    """
    N = integer("N", N, error=SignalError, low=1)
    Ts = real_number("Ts", Ts, error=SignalError, low=0.0, low_open=True)
    if real_number("mean_switch_time", mean_switch_time, error=SignalError) < Ts:
        raise SignalError(
            f"mean_switch_time must be at least Ts = {Ts} (one switch per sample at most), "
            f"got {mean_switch_time!r}"
        )
    table = real_array("levels", levels, error=SignalError)
    table = table[None] if table.ndim == 1 else table
    if table.ndim != 2 or table.shape[1] != 2:
        raise SignalError(f"levels must have shape (2,) or (channels, 2), got {table.shape}")
    if np.any(table[:, 0] == table[:, 1]):
        raise SignalError(f"levels must be two different values for each channel, got {table.tolist()}")
    if switch_within is not None and not 1 < integer("switch_within", switch_within, error=SignalError) <= N:
        raise SignalError(f"switch_within must lie in 2..{N}, got {switch_within!r}")
    integer("seed", seed, error=SignalError, low=0)
    max_draws = integer("max_draws", max_draws, error=SignalError, low=1)
    rng = np.random.default_rng(seed)
    prob = Ts / mean_switch_time
    out = np.empty((N, table.shape[0]))
    for ch, pair in enumerate(table):
        for _ in range(max_draws):
            # A switch at sample k (k >= 1) flips the level from k on.
            flips = rng.random(N) < prob
            flips[0] = False
            state = (rng.integers(2) + np.cumsum(flips)) % 2
            if switch_within is None or flips[1:switch_within].any():
                break
        else:
            raise SignalError(
                f"channel {ch} did not switch in its first {switch_within} samples in "
                f"{max_draws} draws; lower mean_switch_time or raise switch_within"
            )
        out[:, ch] = pair[state]
    return out


def dwell_times(signal: object) -> np.ndarray:
    """Lengths (in samples) of the complete runs of constant value in a 1-D signal.

    The first and last runs are left out: they are cut by the ends of the record.

    Examples
    --------
    >>> dwell_times([0, 0, 1, 1, 1, 0, 1, 1])
    array([3, 1])
    """
    x = np.asarray(signal).reshape(-1)
    switches = np.flatnonzero(x[1:] != x[:-1]) + 1
    return np.diff(switches)
