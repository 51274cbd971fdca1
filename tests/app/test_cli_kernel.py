"""``moli fit --method kernel``: the kernel model and its report; the regularized impulse and step
responses with their bands in every report; bad input in one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import moli
from moli.app import cli
from moli.app.impulse_section import regularized_fit, regularized_responses
from moli.app.report import write_report

IO = ["--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3"]
SECTION = "<h2>Regularized impulse and step responses</h2>"


def run(folder: Path, *args: str):
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(folder)
        return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


@pytest.fixture(scope="module")
def kernel_run(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("kernel")
    moli.to_dataframe(moli.example_data(N=300, seed=1)).to_csv(folder / "plant.csv")
    result = run(folder, "fit", "plant.csv", *IO, "--method", "kernel", "--nmax", "4")
    assert result.exit_code == 0, result.output
    return folder


def test_the_kernel_fit_writes_the_kernel_model(kernel_run):
    model_file = kernel_run / "moli-fit-plant" / "model.json"
    info = json.loads(model_file.read_text())["info"]
    assert info["method"] == "kernel" and info["options"]["method"] == "kernel" and info["options"]["nmax"] == 4
    assert info["data"]["N"] == 210 and info["data"]["validation_N"] == 90 and info["warnings"] == []
    # the computation moli.identify_kernel makes on the same split (the last 30 % held out): the same
    # model, up to the JSON file's 17 significant digits
    estimation, validation = moli.read_data(kernel_run / "plant.csv", ["u1", "u2", "u3"],
                                            ["y1", "y2", "y3"]).split(0.7)
    direct = moli.identify_kernel(estimation, validation, nmax=4).model
    np.testing.assert_allclose(moli.load_model(model_file).A, direct.A, rtol=1e-12, atol=1e-14)


def test_the_kernel_report_shows_the_realizations_and_the_regularized_responses(kernel_run):
    report = kernel_run / "moli-fit-plant" / "report"
    page = (report / "report.html").read_text()
    assert "<h1>moli kernel identification</h1>" in page and SECTION in page
    # every order's realization in the table, and one cell of hyperparameters per input-output pair
    assert page.count("<tr><td>") + page.count('<tr class="selected"><td>') == 4
    assert page.count("lambda = ") == 9
    for name in ("validation", "poles", "step_responses", "magnitude", "regularized_impulse",
                 "regularized_step", "residuals"):
        assert (report / f"{name}.png").stat().st_size > 0, name


@pytest.mark.filterwarnings("ignore::moli.ShortValidationWarning")     # 90 validation samples: not the point here
def test_the_moli_report_has_the_regularized_responses(tmp_path):
    result = moli.identify(moli.example_data(N=300, seed=2), nmax=4)
    page = write_report(result, tmp_path).read_text()
    assert SECTION in page
    # the estimate of moli.impulse_response on the estimation record, pair (y1, u1) first
    fit = moli.impulse_response(result.estimation)
    assert f"c = {fit.hyperparameters[0][0]['c']:.4g}, lambda = {fit.hyperparameters[0][0]['lambda']:.4g}" in page
    assert (tmp_path / "regularized_impulse.png").exists() and (tmp_path / "regularized_step.png").exists()


def test_the_figures_draw_the_estimate_inside_its_bands():
    data = moli.example_data(N=200, seed=3)
    fit = moli.impulse_response(moli.IOData(data.y[:, :2], data.u))      # two outputs, three inputs
    for step in (False, True):
        figure = regularized_responses(fit, step=step)
        axes = np.array(figure.axes).reshape(2, 3)
        lower, upper = fit.bands(0.95, step=step)
        values = fit.step() if step else fit.coefficients
        for j in range(2):
            for i in range(3):
                ax = axes[j, i]
                np.testing.assert_array_equal(ax.lines[0].get_ydata(), values[:, j, i])
                # the shaded band spans the posterior band: its outline's extremes are the band's
                outline = ax.collections[0].get_paths()[0].vertices[:, 1]
                assert outline.min() == pytest.approx(lower[:, j, i].min())
                assert outline.max() == pytest.approx(upper[:, j, i].max())


def test_a_record_without_an_estimate_gives_the_reason_not_an_error():
    data = moli.example_data(N=200, seed=4)
    still = moli.IOData(data.y, np.column_stack([data.u[:, :2], np.ones(data.N)]))
    assert "input u3 never changes" in regularized_fit(still)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    data = moli.example_data(N=200, seed=1)
    moli.to_dataframe(data).to_csv(tmp_path / "good.csv")
    moli.to_dataframe(moli.IOData(data.y, np.column_stack([data.u[:, :2], np.ones(data.N)]))).to_csv(
        tmp_path / "still.csv")
    (tmp_path / "ridge.json").write_text('{"method": "ridge"}')
    (tmp_path / "kernel.json").write_text('{"method": "kernel"}')
    return tmp_path


BAD = [
    (["fit", "good.csv", *IO, "--method", "kernal"], "'--method': 'kernal' is not one of 'moli', 'kernel'"),
    (["fit", "good.csv", *IO, "--options", "ridge.json"], "IdentifyOptions.method"),
    (["fit", "good.csv", *IO, "--method", "kernel", "--order", "3"], "method='kernel' does not read order"),
    (["fit", "good.csv", *IO, "--method", "kernel", "--all-lists"], "--all-lists is for the sampled MOLI search"),
    (["fit", "good.csv", *IO, "--method", "kernel", "--continuous"], "identifies sampled models"),
    (["fit", "still.csv", *IO, "--method", "kernel"], "input u3 never changes"),
    (["fit", "good.csv", "--frequency", "--method", "kernel"], "--method does not apply to --frequency"),
    (["fit", "good.csv", "--frequency", "--options", "kernel.json"], "asks for method='kernel'"),
    (["fit", "good.csv", *IO, "--kernel", "DC"], "kernel must be 'TC' unless method is 'kernel' or 'kernel-arx'"),
    (["fit", "good.csv", "--frequency", "--kernel", "SS"], "--kernel does not apply to --frequency"),
    (["fit", "good.csv", *IO, "--method", "kernel", "--kernel", "gauss"], "'--kernel': 'gauss' is not one of"),
    (["fit-many", *IO, "--out", "many", "good.csv", "--method", "kernel", "--preset", "fast"],
     "method='kernel' does not read"),
]


@pytest.mark.parametrize("args, message", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_kernel_command_lines_end_with_one_error_line(folder, args, message):
    result = run(folder, *args)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("moli: error: ") and message in lines[0], result.stderr
    assert not list(folder.rglob("model.json")) and not list(folder.rglob("report.html"))


def test_fit_many_runs_the_kernel_method_per_record_and_lists_the_one_it_cannot_fit(folder):
    result = run(folder, "fit-many", *IO, "--out", "many", "good.csv", "still.csv", "--method", "kernel",
                 "--nmax", "4", "--workers", "1")
    assert result.exit_code == 1, result.output          # a record failed: listed, the others kept
    saved = json.loads((folder / "many" / "good.json").read_text())
    assert saved["info"]["method"] == "kernel" and saved["info"]["options"]["method"] == "kernel"
    # the same record through moli fit: one method, one model (the same arithmetic in the same process)
    assert run(folder, "fit", "good.csv", *IO, "--method", "kernel", "--nmax", "4", "--out", "one.json").exit_code == 0
    one = json.loads((folder / "one.json").read_text())
    assert saved["A"] == one["A"] and saved["C"] == one["C"]
    assert "input u3 never changes" in (folder / "many" / "summary.csv").read_text()


def test_the_kernel_flag_names_the_prior_of_the_fit_and_of_the_fleet(folder):
    assert run(folder, "fit", "good.csv", *IO, "--method", "kernel", "--kernel", "SS", "--nmax", "4",
               "--out", "ss.json").exit_code == 0
    saved = json.loads((folder / "ss.json").read_text())
    assert saved["info"]["options"]["kernel"] == saved["info"]["kernel"] == "SS"
    estimation, validation = moli.read_data(folder / "good.csv", ["u1", "u2", "u3"], ["y1", "y2", "y3"]).split(0.7)
    direct = moli.identify_kernel(estimation, validation, kernel="SS", nmax=4).model
    # the same computation on the same split, up to the JSON file's 17 significant digits
    np.testing.assert_allclose(moli.load_model(folder / "ss.json").A, direct.A, rtol=1e-12, atol=1e-14)
    assert run(folder, "fit-many", *IO, "--out", "many", "good.csv", "--method", "kernel", "--kernel", "SS",
               "--nmax", "4", "--workers", "1").exit_code == 0
    assert json.loads((folder / "many" / "good.json").read_text())["A"] == saved["A"]


def test_the_kernel_arx_method_writes_its_model_and_report(folder):
    result = run(folder, "fit", "good.csv", *IO, "--method", "kernel-arx", "--kernel", "SS", "--nmax", "4",
                 "--out", "arx.json", "--report", "arx")
    assert result.exit_code == 0, result.output
    saved = json.loads((folder / "arx.json").read_text())
    assert saved["info"]["method"] == saved["info"]["options"]["method"] == "kernel-arx"
    estimation, validation = moli.read_data(folder / "good.csv", ["u1", "u2", "u3"], ["y1", "y2", "y3"]).split(0.7)
    direct = moli.identify_kernel_arx(estimation, validation, kernel="SS", nmax=4).model
    # the same computation on the same split, up to the JSON file's 17 significant digits
    np.testing.assert_allclose(moli.load_model(folder / "arx.json").A, direct.A, rtol=1e-12, atol=1e-14)
    page = (folder / "arx" / "report.html").read_text()
    assert "balanced reduction of the regularized ARX model (SS prior" in page and SECTION in page
    assert run(folder, "fit", "good.csv", *IO, "--method", "kernel-arx", "--seed", "2").exit_code == 2
