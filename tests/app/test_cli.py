"""End-to-end tests of the ``moli`` command: demo, fit, validate, info and bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli, progress
from moli.data.files import fingerprint

INPUTS, OUTPUTS = "u1,u2,u3", "y1,y2,y3"
NMAX = 4  # the path 3, 4: enough to exercise the search and the order rule, fast


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def run_process(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "moli", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=120)


@pytest.fixture
def record() -> moli.IOData:
    return moli.example_data(N=400, seed=3)


@pytest.fixture
def csv_file(tmp_path: Path, record: moli.IOData) -> Path:
    path = tmp_path / "plant.csv"
    moli.to_dataframe(record).to_csv(path)
    return path


def assert_clean_error(result, message: str) -> None:
    """Exit code 2, one error line on stderr naming the problem, no traceback.

    Warning lines may come before it (a file without time says Ts = 1 was assumed).
    """
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit)
    lines = result.stderr.strip().splitlines()
    assert lines[-1].startswith("moli: error: "), result.stderr
    assert all(line.startswith("moli: warning: ") for line in lines[:-1]), result.stderr
    assert message in lines[-1]


def test_demo_in_a_fresh_folder_writes_report_and_model(tmp_path):
    done = run_process("demo", "--nmax", str(NMAX), "--all-lists", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "selected: indices" in done.stdout
    assert "structure search" in done.stderr  # the progress bar
    folder = tmp_path / "moli-demo"
    for name in ("report.html", "vaf_by_order.png", "validation.png", "poles.png",
                 "step_responses.png"):
        assert (folder / name).stat().st_size > 1000, name
    assert "every other list fitted" in (folder / "report.html").read_text()
    model = moli.load_model(folder / "model.json")
    assert (model.p, model.m) == (3, 3) and model.info["data"]["source"] == "moli.example_data()"


def test_fit_validate_info_on_a_csv(tmp_path, csv_file, record):
    model_path, report_dir = tmp_path / "out" / "model.json", tmp_path / "report"
    fitted = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS, "--nmax", str(NMAX),
                 "--validation", "0.4", "--out", str(model_path), "--report", str(report_dir))
    assert fitted.exit_code == 0, fitted.output + fitted.stderr
    assert (report_dir / "report.html").stat().st_size > 1000

    # the command must give exactly the model of the Python API on the same split
    est, val = record.split(0.6)
    expected = moli.identify(est, val, nmax=NMAX).model
    saved = moli.load_model(model_path)
    for name in "ABC":
        np.testing.assert_array_equal(getattr(saved, name), getattr(expected, name))
    assert saved.indices == expected.indices
    np.testing.assert_array_equal(saved.alpha, expected.alpha)
    assert saved.info["data"]["sha256"] == fingerprint(est)
    assert saved.info["options"]["nmax"] == NMAX

    plot = tmp_path / "check.png"
    checked = run("validate", str(model_path), str(csv_file), "--plot", str(plot))
    assert checked.exit_code == 0, checked.stderr
    assert plot.stat().st_size > 1000
    scores = moli.compare(saved, record)
    for name, v, f in zip(record.output_names, scores.vaf, scores.fit):
        assert f"{name:<16}{v:>9.2f}{f:>9.2f}" in checked.output

    described = run("info", str(model_path))
    assert described.exit_code == 0
    assert f"observability indices: {list(saved.indices)}" in described.output
    assert "stable: yes" in described.output and "Ts = 1" in described.output


def test_fit_preset_gives_the_api_model(tmp_path, csv_file, record):
    model_path = tmp_path / "paper.json"
    fitted = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS, "--nmax", str(NMAX),
                 "--preset", "paper", "--out", str(model_path))
    assert fitted.exit_code == 0, fitted.output + fitted.stderr
    est, val = record.split(0.7)
    expected = moli.identify(est, val, nmax=NMAX, preset="paper").model
    saved = moli.load_model(model_path)
    np.testing.assert_array_equal(saved.A, expected.A)
    assert moli.IdentifyOptions.from_dict(saved.info["options"]) == moli.IdentifyOptions.paper(nmax=NMAX)
    # an unknown choice is a usage error, reported by click with the valid choices
    wrong = run("fit", str(csv_file), "--preset", "quick")
    assert wrong.exit_code == 2 and ("'quick' is not one of 'default', 'fast', 'improved', 'bounded', 'paper'"
                                     in wrong.stderr)


def test_fit_fast_preset_saves_its_options_and_the_api_model(tmp_path, csv_file, record):
    model_path = tmp_path / "fast.json"
    fitted = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS, "--nmax", str(NMAX),
                 "--preset", "fast", "--out", str(model_path))
    assert fitted.exit_code == 0, fitted.output + fitted.stderr
    saved = moli.load_model(model_path)
    assert moli.IdentifyOptions.from_dict(saved.info["options"]) == moli.IdentifyOptions.fast(nmax=NMAX)
    est, val = record.split(0.7)
    expected = moli.identify(est, val, nmax=NMAX, preset="fast").model
    # the same search on the same samples: the same arithmetic, so equal to round-off
    np.testing.assert_allclose(saved.A, expected.A, rtol=1e-12, atol=1e-12)
    assert saved.K is not None          # the fast search keeps the noise model


def test_ctrl_c_keeps_the_best_model_so_far(tmp_path, csv_file, monkeypatch):
    calls = []

    def interrupt_on_second_step(self, step):
        calls.append(step)
        if len(calls) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(progress.PathProgress, "__call__", interrupt_on_second_step)
    model_path = tmp_path / "model.json"
    result = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS, "--nmax", "8",
                 "--out", str(model_path))
    assert result.exit_code == 3, result.stderr   # a model written from a partial run
    assert "interrupted after 2 orders" in result.stderr
    assert moli.load_model(model_path).n in (calls[0].order, calls[1].order)


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


BAD_INPUT = {
    "missing file": (lambda d: d / "absent.csv", "no data file at"),
    "unknown column": (lambda d: write(d / "a.csv", "u1,u2,u3,y1,y2,flow\n1,2,3,4,5,6\n"),
                       "no column 'y3'"),
    "non-numeric cell": (lambda d: write(d / "b.csv", "u1,u2,u3,y1,y2,y3\n1,2,3,4,5,6\n1,2,x,4,5,6\n"),
                         "line 3, column 'u3': 'x' is not a number"),
    "too few rows": (lambda d: write(d / "c.csv", "u1,u2,u3,y1,y2,y3\n" + "1,2,3,4,5,6\n" * 12),
                     "too few samples"),
}


@pytest.mark.parametrize("case", BAD_INPUT)
def test_fit_bad_input_is_one_line_and_exit_2(tmp_path, case):
    make, message = BAD_INPUT[case]
    result = run("fit", str(make(tmp_path)), "--inputs", INPUTS, "--outputs", OUTPUTS)
    assert_clean_error(result, message)


def test_validate_model_of_another_shape(tmp_path, csv_file):
    small = tmp_path / "small.json"
    moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], output_names=["y1"], input_names=["u1"]).save(small)
    result = run("validate", str(small), str(csv_file), "--inputs", INPUTS, "--outputs", "y1")
    assert_clean_error(result, "model has 1 outputs and 1 inputs, data have 1 and 3")


def test_model_file_with_inconsistent_matrices(tmp_path, csv_file):
    path = tmp_path / "broken.json"
    content = moli.StateSpaceModel(np.eye(2), np.ones((2, 3)), np.ones((3, 2))).to_dict()
    content["C"] = [[1.0, 0.0, 0.0]]
    path.write_text(json.dumps(content))
    assert_clean_error(run("info", str(path)), "model file is inconsistent")
    content["version"] = "99.0"
    path.write_text(json.dumps(content))
    assert_clean_error(run("validate", str(path), str(csv_file)), "cannot read")


def test_fit_options_file_and_a_saved_model_rerun_the_same_search(tmp_path, csv_file, record):
    opts = moli.IdentifyOptions.bounded(nmax=NMAX, seed=2)
    options_file = tmp_path / "options.json"
    options_file.write_text(json.dumps(opts.to_dict()))
    first, second = tmp_path / "first.json", tmp_path / "second.json"
    for source, out in ((options_file, first), (first, second)):  # the second reads the first model
        done = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS,
                   "--options", str(source), "--out", str(out))
        assert done.exit_code == 0, done.output + done.stderr
    est, val = record.split(0.7)
    expected = moli.identify(est, val, opts).model
    for out in (first, second):
        saved = moli.load_model(out)
        np.testing.assert_array_equal(saved.A, expected.A)
        assert moli.IdentifyOptions.from_dict(saved.info["options"]) == opts
    # a flag beside the file replaces that one field
    done = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS,
               "--options", str(options_file), "--nmax", "3", "--out", str(tmp_path / "third.json"))
    assert done.exit_code == 0, done.stderr
    assert moli.load_model(tmp_path / "third.json").info["options"] == opts.replace(nmax=3).to_dict()


@pytest.mark.parametrize(
    "content, extra, message",
    [
        ({"order_tolerence": 0.5}, [], "did you mean 'order_tolerance'"),
        ({"trend_degree": "2"}, [], "IdentifyOptions.trend_degree must be"),
        ("not json", [], "is not a JSON file"),
        ({}, ["--preset", "paper"], "either --options FILE or --preset"),
    ],
)
def test_fit_bad_options_file(tmp_path, csv_file, content, extra, message):
    path = tmp_path / "options.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    result = run("fit", str(csv_file), "--inputs", INPUTS, "--outputs", OUTPUTS, "--options", str(path), *extra)
    assert_clean_error(result, message)


@pytest.mark.parametrize(
    "args, message",
    [
        (["fit"], "give either DATA files or --daisy NAME"),
        (["fit", "--daisy", "no-such-set"], "no-such-set"),
        (["fit", "FILE", "--inputs", INPUTS, "--outputs", OUTPUTS, "--validation", "1.5"],
         "--validation must be a fraction in (0, 1)"),
    ],
)
def test_fit_option_errors(csv_file, args, message):
    result = run(*[str(csv_file) if a == "FILE" else a for a in args])
    assert_clean_error(result, message)


def test_bad_input_in_a_real_process_has_no_traceback(tmp_path):
    done = run_process("validate", "nothing.json", "nothing.csv", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr == "moli: error: no model file at nothing.json\n"


def test_fit_continuous_reads_jittered_stamps_and_writes_a_continuous_model(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.15, 1499)])
    u = np.repeat(rng.choice([-1.0, 1.0], 150), 10)
    model = moli.ContinuousModel(np.array([[-0.5]]), np.array([[0.5]]), np.array([[2.0]]), np.zeros((1, 1)),
                                 ("y",), ("u",), np.zeros(1), np.zeros(1), (0.0,))
    y = model.simulate(u, t)[:, 0] + 0.01 * rng.standard_normal(t.size)
    data = tmp_path / "jitter.csv"
    data.write_text("time,u,y\n" + "\n".join(f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, u, y)))
    result = run("fit", str(data), "--inputs", "u", "--outputs", "y", "--continuous", "--nmax", "3",
                 "--out", str(tmp_path / "model.json"), "--report", str(tmp_path / "report"))
    assert result.exit_code == 0, result.output
    assert "time constant" in result.output and (tmp_path / "report" / "report.html").exists()
    loaded = moli.load_model(tmp_path / "model.json")
    assert isinstance(loaded, moli.ContinuousModel) and loaded.n == 1
    # a first-order plant at 40 dB on 1500 samples: its pole -0.5 within 2 %
    assert abs(loaded.poles()[0] + 0.5) < 0.01


def test_fit_with_a_reference_column_identifies_the_plant_inputs_by_two_stages(tmp_path):
    from systems_util import pi_loop

    record = pi_loop(0, N=1500)
    table = np.column_stack([record.y, record.u])
    data = tmp_path / "loop.csv"
    data.write_text("y1,y2,u1,u2,r1,r2\n" + "\n".join(",".join(f"{v:.17g}" for v in row) for row in table))
    result = run("fit", str(data), "--inputs", "u1,u2", "--outputs", "y1,y2", "--reference", "r1,r2",
                 "--nmax", "3", "--out", str(tmp_path / "model.json"))
    assert result.exit_code == 0, result.output
    assert "closed loop: two-stage method" in result.output
    loaded = moli.load_model(tmp_path / "model.json")
    assert loaded.input_names == ("u1", "u2") and loaded.info["closed_loop"]["reference"] == ["r1", "r2"]
    refused = run("fit", str(data), "--inputs", "u1,u2", "--outputs", "y1,y2", "--closed-loop", "two-stage",
                  "--out", str(tmp_path / "other.json"))
    assert refused.exit_code == 2
    assert refused.output.count("moli: error:") == 1 and "needs reference" in refused.output


def test_fit_of_a_controllers_output_without_references_says_it_used_the_direct_method(tmp_path):
    from systems_util import pi_loop

    record = pi_loop(1, N=1500)            # PI loops that add no noise to their outputs
    table = np.column_stack([record.y, record.u[:, :2]])
    data = tmp_path / "loop.csv"
    data.write_text("y1,y2,u1,u2\n" + "\n".join(",".join(f"{v:.17g}" for v in row) for row in table))
    result = run("fit", str(data), "--inputs", "u1,u2", "--outputs", "y1,y2", "--order", "2",
                 "--out", str(tmp_path / "model.json"), "--report", str(tmp_path / "report"))
    assert result.exit_code == 0, result.output
    assert "closed loop: direct method: feedback detected" in result.output
    assert "direct method: feedback detected" in (tmp_path / "report" / "report.html").read_text()
    assert moli.load_model(tmp_path / "model.json").info["closed_loop"]["method"] == "direct"
