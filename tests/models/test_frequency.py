"""Frequency response of a model and the spectral estimate from data."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

import moli
from moli.app import frequency_figures

from systems_util import random_system


def test_model_response_is_the_transform_of_its_impulse_response():
    rng = np.random.default_rng(0)
    part = random_system(4, 2, 3, rng)
    model = moli.StateSpaceModel(part.A, part.B, part.C, rng.standard_normal((2, 3)),
                                 Ts=0.5).with_input_delays([0, 2, 5])
    omega = np.linspace(0.0, np.pi / model.Ts, 7)
    # H(w) = sum_k h_k exp(-j w k Ts) from the simulated unit impulses; the spectral
    # radius is 0.9, so the terms beyond 600 samples are below 0.9**600 ~ 1e-27
    count = 600
    impulses = np.zeros((count, 2, 3))
    for j in range(3):
        u = np.zeros((count, 3))
        u[0, j] = 1.0
        impulses[:, :, j] = model.simulate(u)
    phases = np.exp(-1j * np.outer(omega, np.arange(count)) * model.Ts)
    expected = np.einsum("fk,kij->fij", phases, impulses)
    got = model.frequency_response(omega)
    assert got.shape == (7, 2, 3)
    # the same sum evaluated two ways: agreement to round-off of the ~600-term sum
    np.testing.assert_allclose(got, expected, atol=1e-10 * np.abs(expected).max())


def test_model_response_checks_its_argument():
    model = moli.StateSpaceModel([[1.0]], [[1.0]], [[1.0]])    # an integrator: pole at z = 1
    with pytest.raises(moli.DataError, match="pole"):
        model.frequency_response([0.0, 0.1])
    assert model.frequency_response(0.5).shape == (1, 1, 1)
    for bad in ([], [[0.1, 0.2]], [np.nan], "fast"):
        with pytest.raises(moli.DataError, match="omega"):
            model.frequency_response(bad)


def test_siso_estimate_is_welchs_ratio():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(3000)
    y = scipy.signal.lfilter([0.0, 1.0], [1.0, -0.7], u) + 0.2 * rng.standard_normal(3000)
    omega, H = moli.empirical_frequency_response(moli.IOData(y, u, Ts=0.1), nperseg=256)
    # scipy's own Welch cross- and auto-spectra (csd(x, y) = E[conj(X) Y] = S_yu)
    f, S_yu = scipy.signal.csd(u, y, fs=10.0, nperseg=256)
    _, S_uu = scipy.signal.welch(u, fs=10.0, nperseg=256)
    np.testing.assert_allclose(omega, 2 * np.pi * f[1:])
    # two implementations of the same average: agreement to round-off
    np.testing.assert_allclose(H[:, 0, 0], S_yu[1:] / S_uu[1:], rtol=1e-9)


def test_requested_frequencies_match_the_dft_grid():
    data = moli.example_data(N=2000, seed=2)
    omega, H = moli.empirical_frequency_response(data, nperseg=128)
    picked = omega[[0, 9, 40]]
    _, at_picked = moli.empirical_frequency_response(data, omega=picked, nperseg=128)
    # the DTFT of the segments at DFT frequencies is their DFT: agreement to round-off
    np.testing.assert_allclose(at_picked, H[[0, 9, 40]], rtol=1e-9)


def test_mimo_estimate_recovers_the_model_on_noise_free_data():
    rng = np.random.default_rng(3)
    A = np.diag([0.5, -0.3, 0.6])
    model = moli.StateSpaceModel(A, rng.standard_normal((3, 2)), rng.standard_normal((2, 3)))
    u = rng.standard_normal((20000, 2))
    data = moli.IOData(model.simulate(u), u)
    omega, H = moli.empirical_frequency_response(data, nperseg=512)
    exact = model.frequency_response(omega)
    error = np.abs(H - exact) / np.max(np.abs(exact), axis=0)
    # noise-free: what is left is the leakage of the Hann window (resolution 2 pi / 512,
    # response poles 0.3 or more from the unit circle: smooth at that scale) and the
    # averaging of the inputs' finite-sample cross-spectrum over ~80 segments
    assert np.median(error) < 0.005 and error.max() < 0.05


def test_estimate_marks_unexcited_frequencies_and_checks_arguments():
    rng = np.random.default_rng(4)
    u = np.column_stack([rng.standard_normal(1000), np.zeros(1000)])
    data = moli.IOData(rng.standard_normal((1000, 1)), u)
    _, H = moli.empirical_frequency_response(data)
    assert np.all(np.isnan(H))                     # S_uu is singular: u2 has no power
    good = moli.IOData(rng.standard_normal(1000), rng.standard_normal(1000))
    for bad in (4, 2000, 64.0, True):
        with pytest.raises(moli.DataError, match="nperseg"):
            moli.empirical_frequency_response(good, nperseg=bad)
    with pytest.raises(moli.DataError, match="segments"):
        moli.empirical_frequency_response(
            moli.IOData(rng.standard_normal(100), rng.standard_normal((100, 3))), nperseg=100)
    with pytest.raises(moli.DataError, match="IOData"):
        moli.empirical_frequency_response(np.zeros((10, 2)))


def test_bode_figure_draws_every_pair():
    data = moli.example_data(N=1500, seed=5)
    model = moli.example_plant()
    fig = frequency_figures.bode_magnitude(model, data)
    assert len(fig.axes) == model.p * model.m
    assert len(fig.axes[0].lines) == 2               # model and spectral estimate


def test_singular_value_figure_is_the_svd_of_the_response():
    model = moli.example_plant()
    fig = frequency_figures.singular_values(model, moli.example_data(N=1500, seed=5), points=40)
    omega, largest = fig.axes[0].lines[0].get_data()
    # an independent computation of the largest gain over input directions
    H = np.array([model.C @ np.linalg.solve(np.exp(1j * w) * np.eye(model.n) - model.A, model.B) + model.D
                  for w in omega])
    np.testing.assert_allclose(largest, [np.linalg.norm(h, 2) for h in H], rtol=1e-10)  # round-off
    assert len(fig.axes[0].lines) == 2 * min(model.p, model.m)   # model and spectral estimate
