"""The time column's unit travels with the record and the model to every axis and table."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli.app import figures, frequency_figures
from moli.app.describe import describe


def _csv(path, header, times):
    rng = np.random.default_rng(0)
    u = np.repeat(rng.standard_normal(len(times) // 10 + 1), 10)[: len(times)]   # steps held 10 samples
    y = np.convolve(u, 0.5 ** np.arange(8))[: len(times)] + 0.01 * rng.standard_normal(len(times))
    lines = [f"{header},u,y"] + [f"{t},{a:.6f},{b:.6f}" for t, a, b in zip(times, u, y)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("header, unit", [("Time [s]", "s"), ("t (ms)", "ms"), ("time_min", "min"),
                                          ("time", None), ("Zeit", None)])
def test_the_unit_a_time_columns_name_states_is_the_records(tmp_path, header, unit):
    data = moli.read_data(_csv(tmp_path / "r.csv", header, 0.05 * np.arange(200)), ["u"], ["y"])
    assert data.time_unit == unit
    # every record made from it keeps it
    assert data[10:100].time_unit == unit and data.split(0.5)[1].remove_means().time_unit == unit
    assert moli.merge([data, data]).time_unit == unit


def test_date_times_are_seconds(tmp_path):
    stamps = [f"2024-05-01T12:00:{k / 10:04.1f}" for k in range(200)]
    data = moli.read_data(_csv(tmp_path / "r.csv", "Timestamp", stamps), ["u"], ["y"])
    assert data.time_unit == "s" and data.Ts == pytest.approx(0.1)


def test_records_of_other_units_merge_without_one():
    a = moli.IOData(np.zeros(50), np.ones(50), 0.1, time_unit="s")
    b = moli.IOData(np.zeros(50), np.ones(50), 0.1, time_unit="ms")
    assert moli.merge([a, b]).time_unit is None
    with pytest.raises(moli.DataError, match="time_unit must be a str"):
        moli.IOData(np.zeros(5), np.ones(5), time_unit=1)


def test_the_model_carries_the_unit_to_its_axes_and_tables(tmp_path):
    data = moli.read_data(_csv(tmp_path / "r.csv", "Time [s]", 0.05 * np.arange(400)), ["u"], ["y"])
    result = moli.identify(data, nmax=3)
    model = result.model
    assert model.info["time_unit"] == "s"
    model.save(tmp_path / "m.json")
    loaded = moli.load_model(tmp_path / "m.json")
    assert "Ts = 0.05 s" in describe(loaded) and "Ts = 0.05 s" in result.summary()
    assert figures.step_responses(loaded, 40).axes[-1].get_xlabel() == "time (s)"
    assert frequency_figures.bode_magnitude(loaded, points=20).axes[-1].get_xlabel() == "frequency (rad/s)"
    shown = figures.measured_vs_simulated(result.validation, moli.compare(model, result.validation))
    assert shown.axes[-1].get_xlabel() == "time from the start of the record (s)"
    # no unit stated: the labels say so rather than invent one
    bare = moli.identify(moli.IOData(data.y, data.u, 0.05), nmax=3).model
    assert "time_unit" not in bare.info
    assert figures.step_responses(bare, 40).axes[-1].get_xlabel() == "time"


def test_a_continuous_model_states_its_poles_in_the_records_unit(tmp_path):
    data = moli.read_data(_csv(tmp_path / "r.csv", "Time [s]", 0.05 * np.arange(400)), ["u"], ["y"])
    model = moli.identify(data, time="continuous", nmax=2).model
    assert model.info["time_unit"] == "s"
    assert "poles (rad/s)" in model.pole_table()[0]
