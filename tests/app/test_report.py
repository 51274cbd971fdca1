"""The HTML report and its figures."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest

import moli
from moli.app import figures
from moli.app.report import path_table, write_report
from moli.method.search import StructureSearch, exhaustive

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def result() -> moli.IdentificationResult:
    est, val = moli.example_data(N=400, seed=2).split(0.5)
    return moli.identify(est, val, nmax=4)


@pytest.fixture(scope="module")
def written(result, tmp_path_factory) -> tuple[str, object]:
    """The report written once (drawing its figures is most of the cost): page and folder."""
    folder = tmp_path_factory.mktemp("rep")
    return write_report(result, folder).read_text(), folder


def test_report_files_exist_and_html_embeds_every_png(written, result):
    page, folder = written
    embedded = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    names = ["vaf_by_order", "validation", "poles", "step_responses", "magnitude", "residuals"]
    assert len(embedded) == len(names)
    for name, data in zip(names, embedded):
        png = (folder / f"{name}.png").read_bytes()
        assert png.startswith(PNG_MAGIC) and len(png) > 5000, name
        assert base64.b64decode(data) == png
    assert page.count("<tr") == len(result.path) + 1 + 7  # path table + header + model facts


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
    ax = figures.magnitude_responses(model, points=50).axes[0]
    omega, gain = ax.lines[0].get_data()
    z = np.exp(1j * omega * model.Ts)
    expected = np.abs(model.C @ np.linalg.solve(z[:, None, None] * np.eye(model.n) - model.A, model.B) + model.D)
    # the plotted line is |H| itself: round-off only
    np.testing.assert_allclose(gain, expected[:, 0, 0], rtol=1e-10)
    assert omega[-1] == pytest.approx(np.pi / model.Ts) and len(ax.collections) == 1
    assert len(figures.step_responses(model, 20).axes[0].collections) == 1
    bare = moli.StateSpaceModel(model.A, model.B, model.C, model.D)
    assert len(figures.magnitude_responses(bare, points=50).axes[0].collections) == 0
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
