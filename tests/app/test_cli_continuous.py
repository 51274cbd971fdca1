"""The command line on continuous-time models: fit, info, validate, validate-many, fit-many, --options."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli
from moli.data.files import file_sha256, fingerprint

# the records are on jittered stamps, which the readers warn about for sampled models
pytestmark = pytest.mark.filterwarnings("ignore::moli.IrregularSamplingWarning")


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def write_record(path: Path, seed: int, N: int = 300) -> Path:
    """A two-mode plant (time constants 1 and 3.3) on jittered stamps, 1 % output noise."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.15, 0.25, N - 1)])
    u = np.repeat(rng.standard_normal(N // 10), 10)
    plant = moli.ContinuousModel(np.array([[-1.0, 0.0], [0.0, -0.3]]), np.array([[1.0], [0.5]]),
                                 np.array([[1.0, 1.0]]), np.zeros((1, 1)), ("y",), ("u",), np.zeros(1),
                                 np.zeros(1), (0.0,))
    y = plant.simulate(u, t)[:, 0] + 0.01 * rng.standard_normal(N)
    path.write_text("time,u,y\n" + "\n".join(f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, u, y)))
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory) -> tuple[Path, Path]:
    """One continuous fit: its record and its run folder."""
    folder = tmp_path_factory.mktemp("continuous")
    record = write_record(folder / "rec.csv", 0)
    result = run("fit", str(record), "--inputs", "u", "--outputs", "y", "--continuous", "--nmax", "3",
                 "--out", str(folder / "run" / "model.json"), "--report", str(folder / "run" / "report"))
    assert result.exit_code == 0, result.output
    return record, folder / "run"


def test_the_model_file_carries_what_a_sampled_one_does(fitted):
    record, run_folder = fitted
    content = json.loads((run_folder / "model.json").read_text())
    info = content["info"]
    assert content["time"] == "continuous" and info["options"]["time"] == "continuous"
    assert info["options"]["nmax"] == 3 and isinstance(info["warnings"], list)
    assert info["data"]["file_sha256"] == file_sha256(record)
    estimation = moli.read_data(record, ["u"], ["y"]).split(0.7)[0]
    assert info["data"]["sha256"] == fingerprint(estimation) and info["data"]["N"] == estimation.N


def test_the_report_has_the_sampled_report_s_sections(fitted):
    _, run_folder = fitted
    page = (run_folder / "report" / "report.html").read_text()
    for section in ("<h2>Warnings</h2>", "SHA-256 of the input file", "time constant", "Static gains",
                    "Unit-step responses", "<h2>Validation</h2>", "<h2>Residual analysis</h2>", "<h2>Options</h2>"):
        assert section in page, section
    assert (run_folder / "report" / "step_responses.png").exists()


def test_info_describes_the_poles_as_time_constants(fitted):
    _, run_folder = fitted
    result = run("info", str(run_folder / "model.json"))
    assert result.exit_code == 0, result.output
    assert result.output.startswith("continuous-time state-space model: n = ")
    assert "time constant" in result.output and "static gain of y" in result.output
    assert "estimated on " in result.output


def test_validate_scores_on_the_record_s_own_stamps(fitted, tmp_path):
    _, run_folder = fitted
    other = write_record(tmp_path / "new.csv", 1)
    result = run("validate", str(run_folder / "model.json"), str(other), "--x0", "estimate",
                 "--out", str(tmp_path / "check"))
    assert result.exit_code == 0, result.output
    # the scores moli.compare gives on the same file, on its jittered stamps
    model, data = moli.load_model(run_folder / "model.json"), moli.read_data(other, ["u"], ["y"])
    expected = moli.compare(model, data, "estimate")
    assert f"{expected.fit[0]:.2f}" in result.output and (tmp_path / "check" / "validation.png").exists()


def test_fit_many_and_validate_many_on_continuous_models(fitted, tmp_path):
    _, run_folder = fitted
    records = [write_record(tmp_path / f"loop{k}.csv", k) for k in range(2)]
    # the continuous model's options carry their time domain into the fleet
    result = run("fit-many", str(tmp_path / "loop*.csv"), "--inputs", "u", "--outputs", "y", "--options",
                 str(run_folder / "model.json"), "--workers", "1", "--out", str(tmp_path / "models"))
    assert result.exit_code == 0, result.output
    assert "2 models" in result.output and "0 failed" in result.output
    for record in records:
        assert moli.load_model(tmp_path / "models" / f"{record.stem}.json").is_continuous
    # a sampled model beside them: one folder of both kinds
    sampled = run("fit", str(records[0]), "--inputs", "u", "--outputs", "y", "--nmax", "3",
                  "--out", str(tmp_path / "models" / "loop0.json"), "--force")
    assert sampled.exit_code == 0, sampled.output
    checked = run("validate-many", str(tmp_path / "models"), str(tmp_path / "loop*.csv"))
    assert checked.exit_code == 0, checked.output
    assert "2 loops, 0 flagged" in checked.output and "failed" not in checked.output


def test_options_of_a_continuous_model_rerun_in_continuous_time(fitted, tmp_path):
    record, run_folder = fitted
    result = run("fit", str(record), "--inputs", "u", "--outputs", "y", "--options", str(run_folder / "model.json"),
                 "--out", str(tmp_path / "again.json"))
    assert result.exit_code == 0, result.output
    again = moli.load_model(tmp_path / "again.json")
    assert again.is_continuous and again.info["options"]["nmax"] == 3


def test_a_model_file_whose_options_say_the_other_domain_is_refused(fitted, tmp_path):
    record, run_folder = fitted
    content = json.loads((run_folder / "model.json").read_text())
    content["info"]["options"]["time"] = "discrete"
    (tmp_path / "odd.json").write_text(json.dumps(content))
    result = run("fit", str(record), "--inputs", "u", "--outputs", "y", "--options", str(tmp_path / "odd.json"),
                 "--out", str(tmp_path / "odd-model.json"))
    assert result.exit_code == 2
    assert result.output.startswith("moli: error: --options: ") and "continuous-time model" in result.output
    assert result.output.count("\n") == 1


@pytest.mark.parametrize("flag", ["--nmax", "--order"])
def test_an_order_beyond_the_record_is_one_error_line(fitted, tmp_path, flag):
    record, _ = fitted
    result = run("fit", str(record), "--inputs", "u", "--outputs", "y", "--continuous", flag, "100000",
                 "--out", str(tmp_path / "none.json"))
    assert result.exit_code == 2
    last = result.output.strip().splitlines()[-1]
    assert last.startswith(f"moli: error: IdentifyOptions.{flag[2:]} = 100000") and "the largest order is" in last
    assert not (tmp_path / "none.json").exists()
