"""Data-quality screening: each flaw found on a record built to have it, and only there."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import moli
from moli import DataError, DataQualityWarning, OrderBoundWarning
from moli.data import check_data


def record(u: np.ndarray, seed: int = 0) -> moli.IOData:
    """Outputs of a known stable plant driven by ``u`` (so only ``u`` carries flaws)."""
    plant = moli.example_plant()  # 3 inputs: extra columns are ignored, missing ones held at 0
    drive = np.zeros((u.shape[0], plant.m))
    drive[:, : min(plant.m, u.shape[1])] = u[:, : plant.m]
    y = plant.simulate(drive) + 0.01 * np.random.default_rng(seed).standard_normal((u.shape[0], plant.p))
    return moli.IOData(y, u)


def prbs(N: int, m: int, seed: int = 1) -> np.ndarray:
    """Binary inputs held for 3 samples: rich, designed excitation."""
    levels = np.random.default_rng(seed).choice([-1.0, 1.0], size=(N // 3 + 1, m))
    return np.repeat(levels, 3, axis=0)[:N]


def kinds(data: moli.IOData, nmax: int | None = None) -> list[tuple[str, tuple[str, ...]]]:
    return [(issue.kind, issue.channels) for issue in check_data(data, nmax)]


def test_a_designed_binary_input_is_clean():
    # binary signals sit at their extremes with two levels on purpose: no clipping finding
    assert kinds(record(prbs(600, 3)), nmax=10) == []


def test_a_constant_input_is_an_error_that_names_it():
    u = prbs(400, 3)
    u[:, 1] = 2.5
    data = record(u)
    assert kinds(data) == [("constant", ("u2",))]
    with pytest.raises(DataError, match="input 'u2' is constant"):
        moli.identify(data, nmax=4)


def test_a_level_with_round_off_jitter_is_constant_though_identify_centres_it():
    u = prbs(400, 3)
    # 1e-9 of jitter on a level of 20: 5e-11 of the level, a constant plus round-off;
    # centred (as identify screens it) the jitter alone is left, its level in the offset
    u[:, 0] = 20.0 + 1e-9 * np.random.default_rng(2).standard_normal(400)
    data = record(u)
    assert kinds(data.remove_means()) == [("constant", ("u1",))]
    with pytest.raises(DataError, match="input 'u1' is constant"):
        moli.identify(data, nmax=4)


def test_a_nearly_constant_input_warns_and_a_small_one_does_not():
    u = prbs(400, 3)
    clean = record(u)
    u[:, 1] = 20.0 + 20.0 * 3e-7 * prbs(400, 1, seed=3)[:, 0]   # 3e-7 of its level
    data = moli.IOData(clean.y, u)    # the outputs of the clean record: only u2 changes
    assert kinds(data) == [("nearly-constant", ("u2",))]
    with pytest.warns(DataQualityWarning, match=r"input 'u2' is nearly constant: its standard "
                      r"deviation is 3.0e-07 of its level"):
        moli.identify(*data.split(0.7), nmax=4)
    # small about zero is a scale, not a flaw: 1e-7 of amplitude moves by its whole level
    assert kinds(record(1e-7 * prbs(400, 3))) == []


def test_a_duplicate_input_is_flagged_and_still_gives_a_finite_model():
    u = prbs(500, 3)
    u[:, 2] = u[:, 0]
    data = record(u)
    assert kinds(data) == [("collinear", ("u1", "u3"))]
    with pytest.warns(DataQualityWarning, match="u1, u3 are .*linear combinations"):
        result = moli.identify(*data.split(0.7), nmax=4)
    assert np.all(np.isfinite(result.model.A)) and np.all(np.isfinite(result.model.B))


def test_a_single_sine_does_not_excite_high_orders():
    # a sinusoid is persistently exciting of order 2 only (2 lags span its Hankel matrix)
    u = np.sin(0.3 * np.arange(300))[:, None]
    y = np.convolve(u[:, 0], [0.0, 0.5, 0.3])[:300]
    assert ("excitation", ("u1",)) in kinds(moli.IOData(y, u), nmax=8)
    assert ("excitation", ("u1",)) not in kinds(moli.IOData(y, prbs(300, 1)), nmax=8)


def test_clipped_and_quantized_outputs_are_flagged():
    rng = np.random.default_rng(3)
    u = rng.standard_normal((400, 1))
    y = np.convolve(u[:, 0], [0.5, 0.3, 0.1])[:400]
    clipped = np.minimum(y, np.quantile(y, 0.8))      # 20 % of the samples at the sensor's top
    assert ("clipped", ("y1",)) in kinds(moli.IOData(clipped, u))
    coarse = np.round(y / np.ptp(y) * 4)               # five levels
    assert ("quantized", ("y1",)) in kinds(moli.IOData(coarse, u))
    assert kinds(moli.IOData(y, u)) == []


def test_a_clipped_continuous_input_is_flagged():
    u = np.random.default_rng(4).standard_normal((400, 1))
    assert ("clipped", ("u1",)) in kinds(moli.IOData(u[:, 0] * 0.3, np.clip(u, -0.8, 0.8)))


def test_too_short_for_a_feedthrough_is_a_clear_error():
    # 2 outputs, 2 inputs, list (1, 1): output 2 has (p+m) + 1 = 5 parameters, 7 with the
    # feedthrough, so 7 + max(indices) + 1 = 9 samples; without it 7 would do
    u = prbs(8, 2)
    data = moli.IOData(np.column_stack([np.cumsum(u[:, 0]), u[:, 1] - u[:, 0]]), u)
    with pytest.raises(DataError, match="with 2 inputs and a feedthrough needs at least 9 samples"):
        moli.identify(data, data, nmax=2, feedthrough=True)


def test_the_selected_order_at_the_bound_warns():
    est, val = moli.example_data(N=600, seed=1).split(400)   # a 3x3 plant of order 6
    with pytest.warns(OrderBoundWarning, match="nmax = 3"):
        moli.identify(est, val, nmax=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", OrderBoundWarning)
        # the 1-point rule stops below the bound on this record: no warning
        moli.identify(est, val, moli.IdentifyOptions.improved(nmax=9))
        # a fixed order is the caller's choice: the path ends there, and nothing was cut short
        moli.identify(est, val, order=3)
