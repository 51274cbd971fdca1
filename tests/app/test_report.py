"""The HTML report and its figures."""

from __future__ import annotations

import base64
import hashlib
import html
import re
from datetime import datetime

import numpy as np
import pytest

import moli
from moli.app import figures, frequency_figures
from moli.app.report import path_table, validation_caption, write_report
from moli.method.search.greedy_path import StructureSearch, exhaustive
from systems_util import random_system

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def result() -> moli.IdentificationResult:
    est, val = moli.example_data(N=400, seed=2).split(0.5)
    return moli.identify(est, val, nmax=4)


@pytest.fixture(scope="module")
def written(result, tmp_path_factory) -> tuple[str, object, object]:
    """The report written once (drawing its figures is most of the cost): page, folder, input file."""
    folder = tmp_path_factory.mktemp("rep")
    data_file = folder / "plant.csv"
    data_file.write_bytes(b"time,u1,y1\n0,1,2\n")
    return write_report(result, folder, data_file=data_file).read_text(), folder, data_file


def test_report_files_exist_and_html_embeds_every_png(written, result):
    page, folder, data_file = written
    embedded = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    names = ["vaf_by_order", "validation", "poles", "step_responses", "magnitude", "singular_values",
             "regularized_impulse", "regularized_step", "residuals"]
    assert len(embedded) == len(names)
    for name, data in zip(names, embedded):
        png = (folder / f"{name}.png").read_bytes()
        assert png.startswith(PNG_MAGIC) and len(png) > 5000, name
        assert base64.b64decode(data) == png
    assert path_table(result).count("<tr") == len(result.path) + 1  # a row per order and the head
    assert page.count(path_table(result)) == 1

    # provenance: input file and its SHA-256, version, date; every option as a row
    facts = dict(re.findall(r'<th scope="row">([^<]+)</th><td class="text">([^<]*)</td>', page))
    assert facts["input"] == str(data_file)
    assert facts["SHA-256 of the input file"] == hashlib.sha256(b"time,u1,y1\n0,1,2\n").hexdigest()
    assert facts["moli version"] == moli.__version__
    assert datetime.strptime(facts["written (UTC)"], "%Y-%m-%d %H:%M:%S").year >= 2024
    for name, value in result.options.to_dict().items():
        assert facts[name].startswith(html.escape(str(value))), name
    assert facts["selected by"].startswith(html.escape(result.selection))
    assert f"on {result.validation.N} validation samples" in facts["selected by"]
    # the scores: formulas, simulation rather than prediction, and why VAF stops at 0
    for words in ("clipped at 0", "<b>simulation</b>", "not a one-step-ahead prediction",
                  "one diverging output cannot", "a negative fit", validation_caption(result)):
        assert words in page


def test_validation_caption_says_in_which_units_the_outputs_are_drawn():
    est, val = moli.example_data(N=300, seed=2).split(0.5)
    centred = moli.identify(est, val, nmax=3)
    raw = moli.identify(est, val, nmax=3, center=False)
    # identify subtracts the estimation means from the validation record (not its own)
    assert "deviations from the estimation record's means" in validation_caption(centred)
    assert "the recorded values (IdentifyOptions.center is off" in validation_caption(raw)


def test_the_validation_figure_draws_what_its_caption_says():
    # "deviations from the estimation record's means": the measured curve is the raw
    # validation output minus the estimation mean, not minus its own mean
    est, val = moli.example_data(N=300, seed=2).split(0.5)
    result = moli.identify(est, val, nmax=3)
    figure = figures.measured_vs_simulated(result.validation, moli.compare(result.model, result.validation))
    for i, ax in enumerate(figure.axes[: val.p]):
        # one subtraction of round-off
        np.testing.assert_allclose(ax.lines[0].get_ydata(), val.y[:, i] - est.y[:, i].mean(), atol=1e-12)
    assert abs(val.y[:, 0].mean() - est.y[:, 0].mean()) > 1e-3  # the two centrings differ here


def six_output_record() -> moli.IOData:
    """A random stable 6-output, 2-input plant of order 8 with long channel names."""
    rng = np.random.default_rng(8)
    plant = random_system(8, 6, 2, rng)
    u = rng.standard_normal((400, 2))
    names = [f"furnace temperature {k}" for k in range(1, 7)]
    return moli.IOData(plant.simulate(u), u, 0.5, output_names=names, input_names=["gas", "air"])


def test_report_stays_readable_with_six_outputs():
    est, val = six_output_record().split(0.6)
    result = moli.identify(est, val, nmax=7)
    table = path_table(result)
    # the path table numbers the outputs and names them below, so its width does not
    # grow with the names; it scrolls sideways inside the page if need be
    assert re.findall(r"<th>VAF (y\d)</th>", table) == [f"y{k}" for k in range(1, 7)]
    assert "y6 = furnace temperature 6" in table and "<div class='wide'>" in table
    # one panel per output at full height, and a 6-by-2 grid of step responses
    assert len(figures.measured_vs_simulated(val, moli.compare(result.model, val)).axes) == 6
    assert len(figures.step_responses(result.model, 50).axes) == 12


def test_path_table_marks_the_selected_row(result):
    rows = path_table(result).split("<tr")[2:]
    marked = [i for i, row in enumerate(rows) if 'class="selected"' in row]
    assert marked == [result.selected_index]


def test_vaf_figure_draws_path_candidates_and_selection(result):
    search = StructureSearch(result.estimation, result.validation,
                             result.omega)
    tried = exhaustive(search, 4)
    ax = figures.vaf_by_order(result.path, tried, result.selected_index).axes[0]
    dots, line, ring = ax.lines
    assert len(dots.get_xdata()) == len(tried) == 3  # C(3, 2) lists of order 4 with p = 3
    np.testing.assert_array_equal(line.get_ydata(), [st.mean_vaf for st in result.path])
    assert ring.get_xdata()[0] == result.selected.order


def test_poles_mark_unstable_ones_apart():
    model = moli.StateSpaceModel(np.diag([0.5, 1.2]), np.ones((2, 1)), np.ones((1, 2)))
    ax = figures.poles(model).axes[0]
    circle, stable, unstable = ax.lines[:3]
    assert stable.get_xdata().tolist() == [0.5] and unstable.get_xdata().tolist() == [1.2]
    assert ax.get_xlim()[1] >= 1.2


def test_step_response_grid_matches_the_markov_sums(result):
    model = result.model
    samples = figures.settling_samples(model)
    axes = figures.step_responses(model, samples).axes
    assert len(axes) == model.p * model.m
    # a step response is the running sum of the Markov parameters
    expected = np.cumsum(model.markov(samples), axis=0)
    last = axes[model.m * (model.p - 1) + 1].lines[0].get_ydata()  # to the last output from u2
    np.testing.assert_allclose(last, expected[:, -1, 1], rtol=1e-10, atol=1e-12)


def test_magnitude_and_step_figures_shade_the_bands_of_models_with_a_covariance(result):
    model = result.model
    ax = frequency_figures.bode_magnitude(model, points=50).axes[0]
    omega, gain = ax.lines[0].get_data()
    z = np.exp(1j * omega * model.Ts)
    expected = np.abs(model.C @ np.linalg.solve(z[:, None, None] * np.eye(model.n) - model.A, model.B) + model.D)
    # the plotted line is |H| itself: round-off only
    np.testing.assert_allclose(gain, expected[:, 0, 0], rtol=1e-10)
    assert omega[-1] == pytest.approx(np.pi / model.Ts) and len(ax.collections) == 1
    assert len(figures.step_responses(model, 20).axes[0].collections) == 1
    bare = moli.StateSpaceModel(model.A, model.B, model.C, model.D)
    assert len(frequency_figures.bode_magnitude(bare, points=50).axes[0].collections) == 0
    assert len(figures.step_responses(bare, 20).axes[0].collections) == 0


def test_settling_samples_grows_with_the_slowest_pole():
    slow = moli.StateSpaceModel([[0.99]], [[1.0]], [[1.0]])
    assert figures.settling_samples(slow) == int(np.ceil(5 / -np.log(0.99)))
    unstable = moli.StateSpaceModel([[1.5]], [[1.0]], [[1.0]])
    assert figures.settling_samples(unstable, cap=300) == 300


def test_report_has_the_residual_analysis_with_one_verdict_per_output(written):
    page = written[0]
    section = page[page.index("<h2>Residual analysis</h2>"):]
    assert "one-step prediction errors" in section  # identify attached a noise model
    verdicts = re.findall(r"<li>(y\d): residuals", section)
    assert verdicts == ["y1", "y2", "y3"]
    assert "1-25" in section  # 200 validation samples: the default 25 lags need only 104
    # which samples were tested: the last is the validation record's last
    assert re.search(r"tested samples \d+-199 of 200", section)


def test_a_long_records_spectral_estimate_is_drawn_at_a_log_spaced_subset_of_its_frequencies():
    data = moli.example_data(N=20_000, seed=1)          # 1024 estimated frequencies
    model = moli.example_plant()
    estimate = moli.empirical_frequency_response(data)
    assert len(estimate.omega) > frequency_figures.MAX_DRAWN_FREQUENCIES
    omega, gain = frequency_figures.bode_magnitude(model, estimate).axes[0].lines[1].get_data()
    assert len(omega) <= frequency_figures.MAX_DRAWN_FREQUENCIES
    # the low decades, sparser than the log grid, keep every frequency; the top one is thinned
    np.testing.assert_array_equal(omega[:20], estimate.omega[:20])
    assert np.sum(omega > 0.1 * omega[-1]) < np.sum(estimate.omega > 0.1 * omega[-1]) / 2
    # every dot is a frequency of the estimate with its own gain, the lowest and highest kept
    at = np.searchsorted(estimate.omega, omega)
    np.testing.assert_array_equal(estimate.omega[at], omega)
    np.testing.assert_array_equal(np.abs(estimate.response[at, 0, 0]), gain)
    assert omega[0] == estimate.omega[0] and omega[-1] == estimate.omega[-1]
    # the same dots whether the figure is given the record or its estimate
    from_record = frequency_figures.bode_magnitude(model, data).axes[0].lines[1].get_data()[0]
    np.testing.assert_array_equal(from_record, omega)
