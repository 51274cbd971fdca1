"""The coherence of frequency data: its checks, the variance it gives with the number of averages,
the reader's 'coh' columns, and the spectral estimate's (docs/frequency.md §1)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io
import scipy.signal

import moli
from moli import DataError, FrequencyData

OMEGA = np.array([1.0, 2.0, 3.0])


@pytest.mark.parametrize("keywords, message", [
    ({"coherence": [0.5, 1.2, 0.5]}, r"coherence must lie in \[0, 1\].*frequency 2 \(from 1; 2 rad/s\) has 1.2"),
    ({"coherence": [0.5, -0.1, 0.5]}, r"coherence must lie in \[0, 1\].*frequency 2 \(from 1; 2 rad/s\) has -0.1"),
    ({"coherence": [0.5, np.nan, 0.5]}, r"coherence has NaN or inf at frequency 2 \(from 1"),
    ({"coherence": [0.5, 0.5]}, r"coherence must have shape \(3, 1, 1\) \(like G\) or \(3,\)"),
    ({"coherence": np.full((3, 2, 1), 0.5)}, r"coherence must have shape \(3, 1, 1\)"),
    ({"averages": 4}, "averages turns a coherence into a variance: give it with coherence and without variance"),
    ({"averages": 4, "coherence": [0.5] * 3, "variance": [1.0] * 3}, "give it with coherence and without variance"),
    ({"averages": 0, "coherence": [0.5] * 3}, "averages must be a positive integer"),
    ({"averages": 2.5, "coherence": [0.5] * 3}, "averages must be a positive integer"),
    ({"averages": 4, "coherence": [0.5, 1.0, 0.5]}, r"coherence 1 at frequency 2 \(from 1; 2 rad/s\) gives no variance"),
    ({"averages": 4, "coherence": [0.0, 0.5, 0.5]}, r"coherence 0 at frequency 1 \(from 1; 1 rad/s\) gives no variance"),
])
def test_bad_coherence_or_averages_is_one_clear_error(keywords, message):
    with pytest.raises(DataError, match=message):
        FrequencyData(OMEGA, [1.0, 1.0j, -1.0], unit="rad/s", **keywords)


def test_the_coherence_is_kept_read_only_and_follows_the_lines_and_pairs():
    coherence = np.linspace(0.1, 0.9, 12).reshape(3, 2, 2)
    data = FrequencyData(OMEGA, np.ones((3, 2, 2)), unit="rad/s", coherence=coherence)
    assert data.variance is None                          # without averages it is only shown
    np.testing.assert_array_equal(data.coherence, coherence)
    with pytest.raises(ValueError):
        data.coherence[0, 0, 0] = 0.5
    np.testing.assert_array_equal(data.lines([0, 2]).coherence, coherence[[0, 2]])
    np.testing.assert_array_equal(data.pairs(slice(None), [1], [0]).coherence, coherence[:, 1:, :1])


def test_the_variance_from_the_coherence_is_the_h1_estimates_spread():
    # Each line: n averages of a complex Gaussian input U with power S_uu through G, plus circular
    # noise V of power s2; the H1 estimate sum(Y U*) / sum(|U|^2). Its true coherence is
    # |G|^2 S_uu / (|G|^2 S_uu + s2), so the rule (1 - coh) |G|^2 / (n coh) = s2 / (n S_uu); the exact
    # mean square error is s2 / ((n - 1) S_uu) (sum |U|^2 is Gamma(n) distributed), n / (n - 1) = 1.032
    # times the rule at n = 32. A line's squared error has a relative sd near 1, so its mean over 300
    # records one of 6 %, and the sum over 400 lines of unequal noise (some 300 lines' worth) one of
    # 0.35 %: the pooled ratio lies within 1 % (3 sd) of 1.032, inside [0.99, 1.08], and a factor 2
    # (the variance of |G| alone, or a coherence read as its square root) falls far outside.
    rng = np.random.default_rng(3)
    lines, records, n = 400, 300, 32
    G = rng.standard_normal(lines) + 1j * rng.standard_normal(lines)
    s_uu, s2 = 1.0, rng.uniform(0.05, 2.0, lines)
    U = (rng.standard_normal((records, n, lines)) + 1j * rng.standard_normal((records, n, lines))) / np.sqrt(2)
    V = np.sqrt(s2 / 2) * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape))
    H1 = np.sum((G * U + V) * U.conj(), axis=1) / np.sum(np.abs(U) ** 2, axis=1)
    coherence = np.abs(G) ** 2 * s_uu / (np.abs(G) ** 2 * s_uu + s2)
    data = FrequencyData(np.arange(1.0, lines + 1), G, unit="rad/s", coherence=coherence, averages=n)
    pooled = np.sum(np.mean(np.abs(H1 - G) ** 2, axis=0)) / np.sum(data.variance[:, 0, 0])
    assert 0.99 <= pooled <= 1.08, pooled


def _table(tmp_path, extra):
    header = ["frequency_hz", "y1/u1 re", "y1/u1 im", "y2/u1 re", "y2/u1 im", *extra]
    rows = [[1, 1.0, 0.0, 0.5, -0.5], [2, 0.5, -0.5, 0.25, -0.25], [3, 0.2, -0.4, 0.1, -0.1]]
    values = {"y1/u1 coh": [0.9, 0.8, 0.5], "y2/u1 coh": [0.99, 0.6, 0.25], "y1/u1 var": [0.01, 0.02, 0.03],
              "y2/u1 var": [0.04, 0.05, 0.06]}
    text = [",".join(header)] + [",".join(str(v) for v in row + [values[p][k] for p in extra])
                                 for k, row in enumerate(rows)]
    path = tmp_path / "frf.csv"
    path.write_text("\n".join(text) + "\n")
    return path


def test_the_reader_takes_coh_columns_and_with_averages_gives_the_variance(tmp_path):
    path = _table(tmp_path, ["y1/u1 coh", "y2/u1 coh"])
    with pytest.warns(moli.FrequencyConventionWarning, match="coherence of each line from the 'coh' columns"):
        shown = moli.read_frequency_data(path)
    np.testing.assert_allclose(shown.coherence[:, :, 0], [[0.9, 0.99], [0.8, 0.6], [0.5, 0.25]])
    assert shown.variance is None
    with pytest.warns(moli.FrequencyConventionWarning, match="the variance from it and 10 averages"):
        weighed = moli.read_frequency_data(path, averages=10)
    coherence = shown.coherence
    np.testing.assert_allclose(weighed.variance, (1 - coherence) * np.abs(shown.G) ** 2 / (10 * coherence))
    both = moli.read_frequency_data(_table(tmp_path, ["y1/u1 coh", "y2/u1 coh", "y1/u1 var", "y2/u1 var"]))
    np.testing.assert_allclose(both.variance[:, :, 0], [[0.01, 0.04], [0.02, 0.05], [0.03, 0.06]])
    assert both.coherence is not None


def test_a_coherence_column_for_some_pairs_only_or_out_of_range_is_refused(tmp_path):
    with pytest.raises(DataError, match="give every pair a 'coh' column or none; missing for y2/u1"):
        moli.read_frequency_data(_table(tmp_path, ["y1/u1 coh"]))
    path = tmp_path / "bad.csv"
    path.write_text("frequency_hz,y1/u1 re,y1/u1 im,y1/u1 coh\n1,1,0,0.5\n2,1,0,1.5\n")
    with pytest.raises(DataError, match=r"bad.csv: coherence must lie in \[0, 1\].*frequency 2 "):
        moli.read_frequency_data(path)


def test_a_mat_file_gives_its_coherence_shaped_as_g(tmp_path):
    G = np.ones((3, 2, 1), complex)
    coherence = np.array([[[0.9], [0.8]], [[0.7], [0.6]], [[0.5], [0.4]]])
    scipy.io.savemat(tmp_path / "frf.mat", {"G": G, "frequency_hz": OMEGA, "coherence": coherence})
    with pytest.warns(moli.FrequencyConventionWarning, match="and coherence"):
        data = moli.read_frequency_data(tmp_path / "frf.mat", averages=5)
    np.testing.assert_allclose(data.coherence, coherence)
    np.testing.assert_allclose(data.variance, (1 - coherence) / (5 * coherence))


def test_the_spectral_estimate_carries_the_coherence_scipy_computes_and_one_where_no_noise():
    plant = moli.StateSpaceModel([[0.8, 0.3], [-0.3, 0.8]], [[1.0], [0.5]], [[1.0, 0.0]])
    rng = np.random.default_rng(11)
    u = rng.standard_normal((4096, 1))
    y = plant.simulate(u) + 0.5 * rng.standard_normal((4096, 1))
    frf = moli.spectral_frequency_data(moli.IOData(y, u), nperseg=256)
    # scipy's Welch coherence: Hann segments overlapping by half, each segment's mean removed, as here
    hz, expected = scipy.signal.coherence(u[:, 0], y[:, 0], nperseg=256)
    expected = np.interp(frf.hz, hz, expected)
    # the two differ by the order of floating-point sums only
    np.testing.assert_allclose(frf.coherence[:, 0, 0], expected, rtol=1e-9)
    # two inputs through a static gain without noise: each output is all the inputs' (no leakage
    # either), so its multiple coherence is 1 up to round-off; the ordinary coherence with one input
    # would be about half
    inputs = rng.standard_normal((4096, 2))
    clean = moli.spectral_frequency_data(moli.IOData(inputs @ np.array([[1.0, 0.5], [-0.7, 1.0]]).T
                                                     + 1e-6 * rng.standard_normal((4096, 2)), inputs), nperseg=128)
    # the 1e-6 noise (kept so that each line has a variance) leaves 1e-12 of each output's power
    np.testing.assert_allclose(clean.coherence, 1.0, atol=1e-10)
