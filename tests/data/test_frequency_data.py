"""FrequencyData, its CSV reader and the frequency response of periodic records (docs/frequency.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import moli
from moli import DataError, FrequencyConventionWarning, FrequencyData


def first_order(omega: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + 1j * omega)


# --- the object -----------------------------------------------------------------------------

def test_hz_are_stored_as_rad_per_time_unit_and_the_points_follow_the_time_base():
    data = FrequencyData([0.5, 1.0], [1.0, 2.0j], unit="Hz")
    assert np.allclose(data.omega, [np.pi, 2 * np.pi]) and np.allclose(data.hz, [0.5, 1.0])
    assert data.G.shape == (2, 1, 1) and np.allclose(data.points, 1j * data.omega)
    sampled = FrequencyData([0.5, 1.0], [1.0, 2.0j], unit="rad/s", Ts=0.1)
    assert np.allclose(sampled.points, np.exp(0.1j * np.array([0.5, 1.0])))


def test_a_1d_variance_is_every_pair_of_its_line_and_the_arrays_are_read_only_copies():
    G = np.ones((3, 2, 2), complex)
    data = FrequencyData([1, 2, 3], G, unit="rad/s", variance=[1.0, 2.0, 3.0], output_names=["a", "b"])
    assert data.variance.shape == (3, 2, 2) and np.all(data.variance[1] == 2.0)
    assert data.output_names == ("a", "b") and data.input_names == ("u1", "u2")
    G[0, 0, 0] = 5.0
    assert data.G[0, 0, 0] == 1.0
    with pytest.raises(ValueError):
        data.G[0, 0, 0] = 3.0


def test_lines_picks_lines_with_their_variance():
    data = FrequencyData([1, 2, 3, 4], np.arange(4.0), unit="rad/s", variance=[1, 2, 3, 4])
    picked = data.lines([1, 3])
    assert np.allclose(picked.omega, [2, 4]) and np.allclose(picked.variance[:, 0, 0], [2, 4])


@pytest.mark.parametrize("frequencies, G, keywords, message", [
    ([1.0, 3.0, 2.0], [1, 1, 1], {}, r"increase strictly: frequency 3 \(from 1; 2 rad/s\) does not exceed frequency 2"),
    ([1.0, 2.0, 2.0], [1, 1, 1], {}, "increase strictly: frequency 3"),
    ([-1.0, 2.0, 3.0], [1, 1, 1], {}, r"zero or positive: frequency 1 \(from 1\) is -1"),
    ([1.0, np.nan, 3.0], [1, 1, 1], {}, "frequencies must be finite: frequency 2"),
    ([1.0, 2.0, 3.0], [1, np.nan, 1], {}, r"NaN or inf at frequency 2 \(from 1; 2 rad/s\)"),
    ([1.0, 2.0, 3.0], [1, 1], {}, r"shape \(F, p, m\) with F = 3"),
    ([1.0, 2.0, 3.0], np.ones((3, 2, 2)), {"output_names": ["y1"], "input_names": ["u1", "u2"]},
     "G has 2 outputs and 2 inputs, but the names give 1 outputs and 2 inputs"),
    ([1.0, 2.0, 3.0], np.ones((3, 2, 2)), {"output_names": ["y1", "y2", "y3"]}, "output_names has 3 names for 2"),
    ([1.0, 2.0, 40.0], [1, 1, 1], {"Ts": 0.1}, r"line 2 \(40 rad/s\) lies above the Nyquist frequency"),
    ([1.0, 2.0, 3.0], [1, 1, 1], {"variance": [1.0, 0.0, 1.0]}, r"variance must be positive: line 1"),
    ([1.0, 2.0, 3.0], [1, 1, 1], {"variance": [1.0, 1.0]}, "variance must have shape"),
    ([1.0, 2.0, 3.0], [1, 1, 1], {"unit": "kHz"}, "unit must be one of"),
])
def test_bad_input_is_one_clear_error_naming_the_argument_and_line(frequencies, G, keywords, message):
    keywords = {"unit": "rad/s", **keywords}
    with pytest.raises(DataError, match=message):
        FrequencyData(frequencies, G, **keywords)


def test_the_nyquist_frequency_itself_is_a_line_of_sampled_data():
    data = FrequencyData([1.0, np.pi / 0.1], [1, 1], unit="rad/s", Ts=0.1)
    assert data.F == 2


# --- the reader ------------------------------------------------------------------------------

def write_table(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v!r}" for v in row) for row in rows) + "\n")
    return path


def two_by_one(omega):
    """The response the tables below hold: y1 <- 1 / (1 + s), force <- 2 / (1 + s)."""
    return np.stack([first_order(omega), 2 * first_order(omega)], axis=1)[:, :, None]


@pytest.mark.parametrize("unit_column, parts, to_columns", [
    ("frequency_rad_s", ("re", "im"), lambda g: (g.real, g.imag)),
    ("frequency_hz", ("dB", "deg"), lambda g: (20 * np.log10(np.abs(g)), np.degrees(np.angle(g)))),
    ("frequency_rad_s", ("mag", "rad"), lambda g: (np.abs(g), np.angle(g))),
    ("Frequency_Hz", ("MAG", "Deg"), lambda g: (np.abs(g), np.degrees(np.angle(g)))),
])
def test_each_convention_reads_the_same_response_and_says_which_it_read(tmp_path, unit_column, parts, to_columns):
    values = np.array([0.5, 1.0, 4.0])
    omega = values * (2 * np.pi if unit_column.lower() == "frequency_hz" else 1.0)
    truth = two_by_one(omega)
    header, columns = [unit_column], [values]
    for index, name in enumerate(["y1", "force"]):
        first, second = to_columns(truth[:, index, 0])
        header += [f"{name}/u1 {parts[0]}", f"{name}/u1 {parts[1]}"]
        columns += [first, second]
    path = write_table(tmp_path / "frf.csv", header, np.column_stack(columns).tolist())
    with pytest.warns(FrequencyConventionWarning) as caught:
        data = moli.read_frequency_data(path)
    assert np.allclose(data.G, truth, rtol=1e-12) and np.allclose(data.omega, omega)
    assert data.output_names == ("y1", "force") and data.input_names == ("u1",)
    said = str(caught[0].message)
    assert unit_column in said and ("dB" in said) == (parts[0] == "dB") and "continuous time" in said


def test_channel_names_and_the_pair_grid_come_from_the_headers(tmp_path):
    header = ["frequency_rad_s", "a/u1 re", "a/u1 im", "a/v re", "a/v im", "b/u1 re", "b/u1 im", "b/v re", "b/v im"]
    rows = [[1.0, 1, 0, 2, 0, 3, 0, 4, 0], [2.0, 5, 1, 6, 1, 7, 1, 8, 1]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FrequencyConventionWarning)
        data = moli.read_frequency_data(write_table(tmp_path / "frf.csv", header, rows), Ts=0.1)
    assert data.output_names == ("a", "b") and data.input_names == ("u1", "v") and data.Ts == 0.1
    assert np.allclose(data.G[1], [[5 + 1j, 6 + 1j], [7 + 1j, 8 + 1j]])


@pytest.mark.parametrize("header, rows, message", [
    (["f", "y1/u1 re", "y1/u1 im"], [[1, 1, 0]], "exactly one frequency column.*found none"),
    (["frequency_hz", "frequency_rad_s", "y1/u1 re", "y1/u1 im"], [[1, 2, 1, 0]], "found 'frequency_hz' and"),
    (["frequency_hz", "y1/u1 re", "y1/u1 im", "note"], [[1, 1, 0, 3]], "column 'note' is neither"),
    (["frequency_hz", "y1/u1 re", "y1/u1 deg"], [[1, 1, 0]], "pair y1/u1 has the parts"),
    (["frequency_hz", "y1/u1 re", "y1/u1 im", "y1/u2 dB", "y1/u2 deg"], [[1, 1, 0, 0, 0]], "mix conventions"),
    (["frequency_hz", "y1/u1 re", "y1/u1 im", "y2/u2 re", "y2/u2 im"], [[1, 1, 0, 1, 0]],
     "missing y1/u2, y2/u1"),
    (["frequency_hz", "y1/u1 re", "y1/u1 im"], [[1, 1, 0], [2, "'x'", 0]], "row 3 .* not a number"),
    (["frequency_hz", "y1/u1 re", "y1/u1 im"], [[2, 1, 0], [1, 1, 0]], "frf.csv: frequencies must increase"),
])
def test_a_table_outside_the_convention_is_one_error_naming_the_file_and_column(tmp_path, header, rows, message):
    path = tmp_path / "frf.csv"
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(str(v).strip("'") for v in r) for r in rows) + "\n")
    with pytest.raises(DataError, match=message):
        moli.read_frequency_data(path)


# --- periodic records ------------------------------------------------------------------------

def periodic_record(model, inputs_per_period, periods, noise, seed):
    """``periods`` periods of the steady-state response to a repeated input, plus white output noise."""
    u = np.tile(inputs_per_period, (periods + 3, 1))
    y = model.simulate(u)[3 * len(inputs_per_period):]          # three periods to reach the steady state
    u = u[3 * len(inputs_per_period):]
    y = y + noise * np.random.default_rng(seed).standard_normal(y.shape)
    return moli.IOData(y, u, Ts=model.Ts)


def multisine(length, lines, seed):
    phases = np.random.default_rng(seed).uniform(0, 2 * np.pi, len(lines))
    t = np.arange(length)
    return np.sum([np.cos(2 * np.pi * k * t / length + phi) for k, phi in zip(lines, phases)], axis=0)


PLANT = moli.StateSpaceModel([[1.5, -0.7], [1.0, 0.0]], [[1.0], [0.0]], [[0.2, 0.1]], Ts=0.5)


def test_noise_free_periods_give_the_true_response_at_the_excited_lines_only():
    lines = np.arange(1, 60, 3)
    record = periodic_record(PLANT, multisine(256, lines, 0)[:, None], 4, 0.0, 1)
    frf = moli.frequency_response(record, 4)
    assert np.allclose(frf.omega, 2 * np.pi * lines / (256 * 0.5))
    truth = PLANT.frequency_response(frf.omega)
    assert np.allclose(frf.G, truth, rtol=1e-9, atol=0)
    assert frf.Ts == 0.5 and frf.output_names == record.output_names


def test_the_variance_from_the_periods_spread_matches_the_noise_it_came_from():
    # white output noise of variance s2 gives each period's DFT bin variance N_p s2, their mean
    # over P periods N_p s2 / P, and G = Y / U the variance N_p s2 / (P |U|^2). Each line's
    # estimate has 2 (P - 1) = 14 degrees of freedom (relative spread 0.38); the mean ratio over
    # 80 lines spreads by 0.38 / sqrt(80) = 0.042, so 0.85-1.15 is 3.5 standard errors.
    length, periods, noise = 512, 9, 0.05
    lines = np.arange(2, 162, 2)
    u = multisine(length, lines, 3)[:, None]
    frf = moli.frequency_response(periodic_record(PLANT, u, periods, noise, 4), periods, transient=1)
    U = np.fft.rfft(u[:, 0])[lines]
    truth = length * noise**2 / ((periods - 1) * np.abs(U) ** 2)
    ratio = frf.variance[:, 0, 0] / truth
    assert 0.85 < ratio.mean() < 1.15


def test_two_inputs_take_two_records_and_give_the_whole_matrix():
    plant = moli.StateSpaceModel([[0.6, 0.2], [0.0, 0.3]], [[1.0, 0.0], [0.5, 1.0]], [[1.0, 0.0], [0.3, 1.0]], Ts=1.0)
    lines = np.arange(1, 30, 2)
    records = [periodic_record(plant, np.column_stack([multisine(128, lines, s), multisine(128, lines, s + 9)]),
                               3, 0.0, s) for s in (0, 1)]
    frf = moli.frequency_response(records, 3)
    assert np.allclose(frf.G, plant.frequency_response(frf.omega), rtol=1e-9)


@pytest.mark.parametrize("make, message", [
    (lambda r: ((r, 5), {}), "not a whole number of 5 periods"),
    (lambda r: ((r, 4), {"transient": 3}), "leave 1; the variance needs at least two"),
    (lambda r: (([r, r], 4), {}), "1 inputs need 1 records"),
    (lambda r: ((moli.IOData(np.zeros(512), np.zeros(512)), 4), {}), "no line of the records is excited"),
])
def test_bad_periodic_records_are_one_clear_error(make, message):
    record = periodic_record(PLANT, multisine(128, [3, 5], 0)[:, None], 4, 0.0, 0)
    args, keywords = make(record)
    with pytest.raises(DataError, match=message):
        moli.frequency_response(*args, **keywords)


def _table(tmp_path, spread_parts):
    """A 2x1 table of re/im columns at three lines, with the uncertainty columns given."""
    header = ["frequency_hz", "y1/u1 re", "y1/u1 im", "y2/u1 re", "y2/u1 im", *spread_parts]
    rows = [[1, 1.0, 0.0, 0.5, -0.5], [2, 0.5, -0.5, 0.25, -0.25], [3, 0.2, -0.4, 0.1, -0.1]]
    values = {"y1/u1 var": [0.01, 0.02, 0.03], "y2/u1 var": [0.04, 0.05, 0.06],
              "y1/u1 sd": [0.1, 0.2, 0.3], "y2/u1 sd": [0.2, 0.3, 0.4]}
    lines = [",".join(header)] + [",".join(str(v) for v in row + [values[p][k] for p in spread_parts])
                                  for k, row in enumerate(rows)]
    path = tmp_path / "frf.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("parts, expected", [
    (["y1/u1 var", "y2/u1 var"], [[0.01, 0.04], [0.02, 0.05], [0.03, 0.06]]),
    (["y1/u1 sd", "y2/u1 sd"], [[0.01, 0.04], [0.04, 0.09], [0.09, 0.16]]),     # squared
])
def test_each_lines_uncertainty_is_read_as_its_variance(tmp_path, parts, expected):
    with pytest.warns(moli.FrequencyConventionWarning, match="from the '(var|sd)' columns"):
        data = moli.read_frequency_data(_table(tmp_path, parts))
    np.testing.assert_allclose(data.variance[:, :, 0], expected)


def test_an_uncertainty_column_for_some_pairs_only_is_refused(tmp_path):
    with pytest.raises(moli.DataError, match="the same uncertainty column"):
        moli.read_frequency_data(_table(tmp_path, ["y1/u1 var"]))
    with pytest.raises(moli.DataError, match="the same uncertainty column"):
        moli.read_frequency_data(_table(tmp_path, ["y1/u1 var", "y2/u1 sd"]))


def test_a_workbook_reads_as_its_csv(tmp_path):
    # the same table written as CSV and as the first sheet of a workbook: the same data
    import pandas as pd

    csv = _table(tmp_path, ["y1/u1 sd", "y2/u1 sd"])
    pd.read_csv(csv).to_excel(tmp_path / "frf.xlsx", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", moli.FrequencyConventionWarning)
        from_csv, from_xlsx = moli.read_frequency_data(csv), moli.read_frequency_data(tmp_path / "frf.xlsx")
    np.testing.assert_array_equal(from_xlsx.G, from_csv.G)
    np.testing.assert_array_equal(from_xlsx.variance, from_csv.variance)
    (tmp_path / "broken.xlsx").write_bytes(b"not a workbook")
    with pytest.raises(moli.DataError, match="broken.xlsx: not a readable table"):
        moli.read_frequency_data(tmp_path / "broken.xlsx")


def test_tab_semicolon_decimal_comma_and_parquet_tables_read_as_their_csv(tmp_path):
    # the separator and the decimal mark are found as read_data finds them: a tab-separated file
    # said its frequency column was missing, and a Parquet file was read as text
    import pandas as pd

    csv = _table(tmp_path, ["y1/u1 sd", "y2/u1 sd"])
    frame = pd.read_csv(csv)
    frame.to_csv(tmp_path / "frf.tsv", sep="\t", index=False)
    frame.to_csv(tmp_path / "semicolon.csv", sep=";", decimal=",", index=False)
    frame.to_parquet(tmp_path / "frf.parquet")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", moli.FrequencyConventionWarning)
        expected = moli.read_frequency_data(csv)
        for name in ("frf.tsv", "semicolon.csv", "frf.parquet"):
            data = moli.read_frequency_data(tmp_path / name)
            np.testing.assert_array_equal(data.G, expected.G)
            np.testing.assert_array_equal(data.variance, expected.variance)


def _response(hz):
    """A 2-output, 1-input continuous response at ``hz``: 1 / (s + 1) and 2 / (s + 4)."""
    s = 2j * np.pi * hz
    return np.stack([1 / (s + 1), 2 / (s + 4)], axis=1)[:, :, None]        # (F, 2, 1)


def test_a_mat_file_reads_in_either_convention(tmp_path):
    import scipy.io

    hz = np.array([0.1, 0.5, 1.0, 2.0])
    G = _response(hz)
    scipy.io.savemat(tmp_path / "moli.mat", {"G": G, "frequency_hz": hz, "variance": np.full(G.shape, 1e-4),
                                             "output_names": np.array(["disp", "vel"], dtype=object),
                                             "input_names": np.array(["force"], dtype=object),
                                             "unused": np.zeros(3)})
    # MATLAB's idfrd fields, ResponseData (p, m, F) and Frequency in rad/s by default
    scipy.io.savemat(tmp_path / "idfrd.mat", {"ResponseData": G.transpose(1, 2, 0), "Frequency": 2 * np.pi * hz,
                                              "OutputName": np.array(["disp", "vel"], dtype=object)})
    with pytest.warns(moli.FrequencyConventionWarning, match="G \\(F x p x m\\) with frequency_hz"):
        first = moli.read_frequency_data(tmp_path / "moli.mat")
    with pytest.warns(moli.FrequencyConventionWarning, match="ResponseData \\(p x m x F\\) with Frequency in rad/s"):
        second = moli.read_frequency_data(tmp_path / "idfrd.mat")
    for data in (first, second):
        np.testing.assert_allclose(data.G, G)
        np.testing.assert_allclose(data.omega, 2 * np.pi * hz)
        assert tuple(data.output_names) == ("disp", "vel")
    assert tuple(first.input_names) == ("force",) and first.variance is not None and second.variance is None


def test_a_mat_file_without_the_arrays_says_what_it_needs(tmp_path):
    import scipy.io

    scipy.io.savemat(tmp_path / "other.mat", {"y": np.zeros(4)})
    with pytest.raises(moli.DataError, match="needs G .* or ResponseData .*; it holds y"):
        moli.read_frequency_data(tmp_path / "other.mat")
    scipy.io.savemat(tmp_path / "hz.mat", {"ResponseData": np.ones((1, 1, 3)), "Frequency": [1.0, 2.0, 3.0],
                                           "FrequencyUnit": "cycles"})
    with pytest.raises(moli.DataError, match="FrequencyUnit 'cycles'"):
        moli.read_frequency_data(tmp_path / "hz.mat")
    (tmp_path / "broken.mat").write_bytes(b"MATLAB but not really")
    with pytest.raises(moli.DataError, match="not a readable .mat file"):
        moli.read_frequency_data(tmp_path / "broken.mat")
