"""The synthetic modal systems of benchmarks/frequency.py and the mode errors of benchmarks/frequency_peers.py.

Both benchmarks (docs/frequency.md §8) draw their systems from ``frequency.system`` and
judge every method by ``frequency_peers.mode_errors``: a system whose modes were not the
ones it reports, or a pairing that credited a method with a mode it missed, would make
every figure there wrong without failing anything else. The peers themselves (the
``bench`` extra) are not needed: they are imported only when a fit runs.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import moli
from conftest import REPO, _load_script


@pytest.fixture(scope="module")
def benchmarks():
    saved_path, saved_env = list(sys.path), {}
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        saved_env[name] = os.environ.get(name)
    sys.path.insert(0, str(REPO / "benchmarks"))      # the scripts import each other by name
    try:
        yield (_load_script(REPO / "benchmarks" / "frequency.py"),
               _load_script(REPO / "benchmarks" / "frequency_peers.py"))
    finally:
        sys.path[:] = saved_path
        for name in ("frequency", "single_thread"):
            sys.modules.pop(name, None)
        for name, value in saved_env.items():          # single_thread pins BLAS threads in os.environ
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@pytest.mark.parametrize("modes", [4, 6, 8])
@pytest.mark.parametrize("seed", [0, 7])
def test_the_system_has_the_modes_it_reports(benchmarks, seed, modes):
    frequency, _ = benchmarks
    truth, natural, damping = frequency.system(seed, modes)
    assert truth.A.shape == (2 * modes, 2 * modes) and truth.B.shape == (2 * modes, 2) and truth.C.shape[0] == 3
    found = moli.modes(truth)
    # the modes come from the eigenvalues of 2 x 2 blocks built from (natural, damping):
    # equal to rounding (1e-9 relative leaves a thousand times the eigenvalue solver's error)
    np.testing.assert_allclose([mode.natural_frequency for mode in found], natural, rtol=1e-9)
    np.testing.assert_allclose([mode.damping for mode in found], damping, rtol=1e-9)
    # the ranges: natural frequencies 5-150 rad/s at least 15 % apart, damping 0.5-5 %
    assert np.all((natural >= 5) & (natural <= 150)) and np.all(natural[1:] / natural[:-1] > 1.15)
    assert np.all((damping >= 0.005) & (damping <= 0.05))


def test_four_modes_by_default(benchmarks):
    frequency, _ = benchmarks
    default, given = frequency.system(3), frequency.system(3, 4)
    np.testing.assert_array_equal(default[0].A, given[0].A)
    np.testing.assert_array_equal(default[1], given[1])


def test_mode_errors_pair_each_true_mode_with_one_fitted_mode(benchmarks):
    frequency, peers = benchmarks
    _, natural, damping = frequency.system(0, 4)
    poles = -damping * natural + 1j * natural * np.sqrt(1 - damping**2)
    # any order, with the conjugates, a real pole and a spurious pair
    shuffled = np.concatenate([poles[::-1], np.conj(poles), [-3.0, -400 + 90j]])
    frequency_error, damping_error = peers.mode_errors(shuffled, natural, damping)
    np.testing.assert_allclose(frequency_error, 0, atol=1e-12)
    np.testing.assert_allclose(damping_error, 0, atol=1e-12)

    # a 1 % shift of one natural frequency (damping ratio kept) is that mode's error alone
    moved = poles.copy()
    moved[2] *= 1.01
    frequency_error, damping_error = peers.mode_errors(moved, natural, damping)
    np.testing.assert_allclose(frequency_error, [0, 0, 0.01, 0], atol=1e-12)
    np.testing.assert_allclose(damping_error, 0, atol=1e-12)

    # three fitted modes for four true ones: the mode left without a fitted one is missed, not shared
    crowded = np.concatenate([poles[:2], [poles[2] * 1.001]])
    frequency_error, _ = peers.mode_errors(crowded, natural, damping)
    assert np.isinf(frequency_error[3]) and np.all(np.isfinite(frequency_error[:3]))
    assert np.all(np.isinf(peers.mode_errors(np.zeros(0), natural, damping)[0]))


@pytest.mark.parametrize("seed", [11, 19])
def test_a_sampled_eight_mode_response_on_log_spaced_lines_gives_every_mode_with_the_order_given(benchmarks, seed):
    """Log-spaced lines of a sampled system crowd near z = 1, where the subspace start saw too
    little of the circle and missed a mode on these seeds (docs/frequency.md §2, §8)."""
    frequency, peers = benchmarks
    truth, natural, damping = frequency.system(seed, 8)
    Ts, omega = frequency.lines("discrete")
    G = truth.to_discrete(Ts).frequency_response(omega)
    model = moli.identify(frequency.noisy(G, omega, seed, Ts), order=16).model
    poles = np.log(model.poles().astype(complex)) / Ts
    frequency_error, damping_error = peers.mode_errors(poles, natural, damping)
    # the bounds (0.2 % and 10 %); a missed mode is an infinite error
    assert np.all(frequency_error < 2e-3) and np.all(damping_error < 0.1)
    # with 1-3 % noise on 2000 lines the model errs by a few 1e-3 of the response (docs/frequency.md §8);
    # a missed mode leaves its share of the response, 0.1 or more, unexplained
    assert np.linalg.norm(model.frequency_response(omega) - G) / np.linalg.norm(G) < 0.02
