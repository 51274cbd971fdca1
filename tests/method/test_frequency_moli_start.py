"""The MOLI start on a frequency grid (docs/frequency.md §2b): exact on noise-free responses, and its least
squares is the dense one."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import FrequencyData
from moli.method.frequency.fit_error import response
from moli.method.frequency.modal_form import matrices
from moli.method.frequency.moli_start import moli_start, output_parameters
from moli.method.frequency.orders import fit_domain, problem_on
from moli.method.frequency.settings import frequency_settings


def modal_system(frequencies, dampings, p, m, seed, feedthrough=False):
    """A continuous model with one lightly damped mode per natural frequency and a real pole, random B, C (and D)."""
    n = 2 * len(frequencies) + 1
    A = np.zeros((n, n))
    for i, (wn, zeta) in enumerate(zip(frequencies, dampings)):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[sigma, omega], [-omega, sigma]]
    A[-1, -1] = -3.0
    rng = np.random.default_rng(seed)
    D = rng.standard_normal((p, m)) if feedthrough else np.zeros((p, m))
    return moli.ContinuousModel(A, rng.standard_normal((n, m)), rng.standard_normal((p, n)), D,
                                tuple(f"y{i + 1}" for i in range(p)), tuple(f"u{j + 1}" for j in range(m)),
                                np.zeros(p), np.zeros(m), (0.0,) * m)


def sorted_values(values):
    return values[np.lexsort((values.imag, values.real))]


# Noise-free lines: the observer form holds at every line exactly, so the start is exact up to the
# round-off of its least squares and of the observer form's eigenvalues. That round-off grows with
# the filter's distance from the poles (up to 1e-4 relative for a SISO filter of 7 roots at the
# band's top), which the held-out lines see: the candidate they pick gave 1e-10 or less on these
# systems, and 1e-8 leaves it a margin while failing any model error.
EXACT = 1e-8
TS = 0.01


def exact_case(p, m, Ts, feedthrough):
    truth = modal_system([10.0, 23.0, 41.0], [0.005, 0.02, 0.01], p, m, seed=4, feedthrough=feedthrough)
    plant = truth if Ts is None else truth.to_discrete(Ts)
    omega = np.logspace(0, np.log10(300.0), 600)
    data = FrequencyData(omega, plant.frequency_response(omega), unit="rad/s", Ts=Ts)
    domain = fit_domain(data)
    settings = frequency_settings(moli.IdentifyOptions(feedthrough=feedthrough), domain.continuous, p)
    return plant, data, domain, settings, problem_on(data, domain)


def physical_poles(layout, theta, domain):
    poles = np.linalg.eigvals(matrices(layout, theta)[0])
    return sorted_values(poles * domain.scale if domain.continuous else poles)


@pytest.mark.parametrize("Ts", [None, TS], ids=["continuous", "discrete"])
@pytest.mark.parametrize("p, m, feedthrough", [(1, 1, False), (3, 2, False), (2, 2, True)])
def test_the_moli_start_alone_recovers_the_poles_and_response_of_a_noise_free_system(p, m, feedthrough, Ts):
    plant, data, domain, settings, problem = exact_case(p, m, Ts, feedthrough)
    held = np.arange(2, data.F, 5)
    kept = np.setdiff1d(np.arange(data.F), held)
    start = moli_start(plant.n, problem_on(data.lines(kept), domain), problem_on(data.lines(held), domain),
                       settings, domain.continuous)
    assert start is not None
    assert np.allclose(physical_poles(*start, domain), sorted_values(plant.poles()), rtol=EXACT, atol=0)
    # the response near a resonance of damping 0.005 moves 1 / (2 zeta) = 100 times a pole's relative error
    assert np.max(np.abs(response(*start, problem.points) - data.G)) <= 100 * EXACT * np.max(np.abs(data.G))


def test_an_order_below_the_outputs_has_no_moli_start():
    _, _, domain, settings, problem = exact_case(3, 2, None, False)
    assert moli_start(2, problem, problem, settings, domain.continuous) is None


def dense_parameters(points, G, weights, j, l, divisor, feedthrough):
    """Output ``j``'s weighted least squares written out entry by entry, solved densely on the real rows."""
    F, p, m = G.shape
    rows, targets, row_weights = [], [], []
    for k, point in enumerate(points):
        a = sum(c * point ** (divisor.size - 1 - e) for e, c in enumerate(divisor))
        for c in range(m):
            z = list(G[k, :, c]) + [1.0 if s == c else 0.0 for s in range(m)]
            row = [point**i / a * z[r] for r in range(p + m) for i in range(l)]
            row += [G[k, i, c] for i in range(j)]
            row += [1.0 if s == c else 0.0 for s in range(m)] if feedthrough else []
            rows.append(row)
            targets.append(G[k, j, c])
            row_weights.append(weights[k, j, c])
    X = np.array(rows) * np.array(row_weights)[:, None]
    y = np.array(targets) * np.array(row_weights)
    stacked, target = np.concatenate([X.real, X.imag]), np.concatenate([y.real, y.imag])
    return np.linalg.lstsq(stacked, target, rcond=None)[0], np.linalg.cond(stacked)


@pytest.mark.parametrize("feedthrough", [False, True])
def test_the_least_squares_is_the_dense_weighted_solve_of_the_stacked_real_rows(feedthrough):
    rng = np.random.default_rng(3)
    F, p, m = 1500, 3, 2                 # more lines than one block of the fold (1024)
    points = np.exp(1j * np.linspace(0.01, 3.0, F))
    G = rng.standard_normal((F, p, m)) + 1j * rng.standard_normal((F, p, m))
    weights = rng.uniform(0.5, 2.0, (F, p, m))
    indices = (2, 2, 1)
    divisors = [np.array([1.0, -1.2, 0.5]), np.array([1.0, -1.2, 0.5]), np.array([1.0, -0.6])]
    thetas, cond = output_parameters(points, G, weights, indices, divisors, feedthrough)
    for j, (l, divisor) in enumerate(zip(indices, divisors)):
        dense, dense_cond = dense_parameters(points, G, weights, j, l, divisor, feedthrough)
        # both solve one problem of condition below 1e3 (checked): their solutions agree to its
        # round-off, about cond * 1e-16 relative, so 1e-10 is a wide margin that any wrong column
        # or weight fails by orders of magnitude
        assert dense_cond < 1e3
        assert np.linalg.norm(thetas[j] - dense) <= 1e-10 * np.linalg.norm(dense)
    assert 1.0 <= cond < 1e3


# --- the option: both starts at each order ------------------------------------------------------


def noisy_data(Ts, level, seed):
    truth = modal_system([10.0, 23.0, 41.0], [0.005, 0.02, 0.01], 3, 2, seed=4)
    plant = truth if Ts is None else truth.to_discrete(Ts)
    omega = np.logspace(0, np.log10(300.0), 500)
    G = plant.frequency_response(omega)
    rng = np.random.default_rng(seed)
    spread = level * np.abs(G)
    noise = spread * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
    return plant, FrequencyData(omega, G + noise, unit="rad/s", Ts=Ts, variance=spread**2)


@pytest.mark.parametrize("Ts", [None, TS], ids=["continuous", "discrete"])
def test_both_starts_keep_at_each_order_the_step_the_held_out_lines_prefer(Ts):
    plant, data = noisy_data(Ts, 0.02, seed=1)
    alone = moli.identify(data, nmax=8)
    both = moli.identify(data, nmax=8, frequency_start="both")
    assert [step.order for step in both.path] == [step.order for step in alone.path]
    for mine, theirs in zip(both.path, alone.path):
        # the subspace step is one of the two compared, so the kept one fits the held-out lines no worse
        assert mine.shares.sum() <= theirs.shares.sum()
        assert mine.start == ("subspace" if mine.shares.sum() == theirs.shares.sum() else "moli")
    assert any(step.start == "moli" for step in both.path)
    assert all(step.start == "subspace" for step in alone.path)
    origin = "MOLI" if both.selected.start == "moli" else "subspace"
    assert both.model.info["method"].startswith(f"frequency-domain {origin} start")


@pytest.mark.parametrize("Ts", [None, TS], ids=["continuous", "discrete"])
def test_both_starts_recover_a_noise_free_system(Ts):
    plant, data, _, _, _ = exact_case(3, 2, Ts, False)
    model = moli.identify(data, nmax=8, frequency_start="both").model
    assert model.n == plant.n
    assert np.allclose(sorted_values(model.poles()), sorted_values(plant.poles()), rtol=EXACT, atol=0)


def test_frequency_start_on_a_time_record_is_refused_by_name():
    record = moli.example_data(N=400, seed=1)
    with pytest.raises(moli.OptionError, match="frequency_start='both' applies to frequency data"):
        moli.identify(record, frequency_start="both")
