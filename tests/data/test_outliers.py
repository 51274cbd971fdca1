"""Outliers: injected spikes are all found, clean noise is not flagged, removal restores the fit."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import DataError, DataQualityWarning
from moli.data import check_data

PLANT = moli.example_plant()


def record(N: int, seed: int) -> moli.IOData:
    """The example plant driven by binary steps plus noise: continuous-valued inputs (screened too)."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.choice([-1.0, 1.0], size=(N // 4 + 1, 3)), 4, axis=0)[:N] + 0.2 * rng.standard_normal((N, 3))
    return moli.IOData(PLANT.simulate(u) + 0.05 * rng.standard_normal((N, 3)), u)


@pytest.fixture(scope="module")
def spiked() -> tuple[moli.IOData, moli.IOData, np.ndarray]:
    """A record, the same with 8 spikes on y2 and 4 on u1 of 12 standard deviations, and where."""
    clean = record(1500, 1)
    rng = np.random.default_rng(5)
    # at least 15 samples apart: isolated glitches, each alone in its median window
    where = rng.choice(np.arange(5, 1495, 15), size=12, replace=False)
    sign = rng.choice([-1.0, 1.0], size=12)
    y, u = clean.y.copy(), clean.u.copy()
    y[where[:8], 1] += sign[:8] * 12 * y[:, 1].std()
    u[where[8:], 0] += sign[8:] * 12 * u[:, 0].std()
    truth = np.zeros((1500, 6), dtype=bool)
    truth[where[:8], 1] = truth[where[8:], 3] = True
    return clean, moli.IOData(y, u), truth


def test_every_injected_spike_is_found_and_nothing_else(spiked):
    clean, bad, truth = spiked
    report = moli.flag_outliers(bad)
    np.testing.assert_array_equal(report.mask, truth)
    assert report.counts == {"y2": 8, "u1": 4}
    assert report.first == {"y2": int(np.argmax(truth[:, 1])), "u1": int(np.argmax(truth[:, 3]))}
    assert not moli.flag_outliers(clean)


def test_white_gaussian_noise_is_not_flagged():
    # the deviation of white noise from its median of 7 has a variance 0.93 of the noise's:
    # were it Gaussian, z > 6 would have probability 4e-10 per sample, 2e-4 expected flags
    # in these 4e5 samples. Zero flags is the claim; one would mean a far heavier tail.
    flags = 0
    for seed in range(20):
        x = np.random.default_rng(seed).standard_normal((10_000, 2))
        flags += int(moli.flag_outliers(moli.IOData(x[:, :1], x[:, 1:])).mask.sum())
    assert flags == 0


def test_the_screening_warns_naming_channel_count_and_first_sample(spiked):
    _, bad, truth = spiked
    issues = [issue for issue in check_data(bad) if issue.kind == "outliers"]
    assert [issue.channels for issue in issues] == [("y2",), ("u1",)]
    first = int(np.argmax(truth[:, 1]))
    assert f"output 'y2' has 8 outlier(s), the first at sample {first}" in issues[0].message
    with pytest.warns(DataQualityWarning, match="input 'u1' has 4 outlier"):
        moli.data.screen(bad)


def test_removal_restores_the_fit(spiked):
    clean, bad, _ = spiked
    validation = record(800, 2)
    vaf = {name: moli.compare(moli.identify(d, nmax=6).model, validation).vaf
           for name, d in (("clean", clean), ("spiked", bad), ("removed", moli.remove_outliers(bad)))}
    # the spikes cost the fit visibly (measured: 0.9 points of VAF on y2)...
    assert np.max(vaf["clean"] - vaf["spiked"]) > 0.5
    # ...and interpolating 12 of 1500 samples gives it back to round-off of the noise
    # (measured within 0.01 points)
    np.testing.assert_allclose(vaf["removed"], vaf["clean"], atol=0.05)


def test_removal_interpolates_only_the_outliers_and_leaves_the_record_alone(spiked):
    _, bad, truth = spiked
    y_given, u_given = bad.y.copy(), bad.u.copy()
    cleaned = moli.remove_outliers(bad)
    assert np.array_equal(bad.y, y_given) and np.array_equal(bad.u, u_given)
    both, given = np.c_[cleaned.y, cleaned.u], np.c_[y_given, u_given]
    np.testing.assert_array_equal(both[~truth], given[~truth])
    k = int(np.argmax(truth[:, 1]))
    assert both[k, 1] == pytest.approx((given[k - 1, 1] + given[k + 1, 1]) / 2)
    assert cleaned.output_names == bad.output_names and cleaned.Ts == bad.Ts


def test_a_designed_input_is_not_screened():
    u = np.zeros((400, 1))
    u[::37] = 1.0  # single-sample pulses of a two-level test signal: intended, not glitches
    report = moli.flag_outliers(moli.IOData(np.random.default_rng(0).standard_normal(400), u))
    assert report.screened == (True, False) and not report


@pytest.mark.parametrize("threshold", [0.0, -1.0, "6", float("nan"), None])
def test_a_bad_threshold_is_refused(threshold, spiked):
    with pytest.raises(DataError, match="threshold must"):
        moli.flag_outliers(spiked[1], threshold)
    with pytest.raises(DataError, match="data must be an IOData"):
        moli.flag_outliers(spiked[1].y)
