"""moli fit FILE --frequency: the pairs named as channels, the model file, the summary, the report, the refusals."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result

import moli
from moli.app import cli, frequency_fit
from moli.app.frequency_report import write_frequency_report
from moli.data.files import file_sha256

# The plant: force to displacement, velocity and acceleration of two modes (natural frequencies
# 4 and 30 rad/s, damping ratios 5 % and 0.83 %); 400 lines log-spaced over 0.1-10 Hz.
NATURAL = np.array([4.0, 30.0])
DAMPING = np.array([0.05, 0.25 / 30.0])
HZ = np.logspace(-1, 1, 400)


def responses(hz: np.ndarray) -> dict[str, np.ndarray]:
    s = 2j * np.pi * hz
    modes = [1 / (s**2 + 2 * z * w * s + w**2) for w, z in zip(NATURAL, DAMPING)]
    displacement = 3.0 * modes[0] + 200.0 * modes[1]
    return {"disp/force": displacement, "vel/force": s * displacement, "accel/force": s**2 * displacement}


def write_frf(path: Path) -> Path:
    """The three pairs as real and imaginary parts, noise-free."""
    columns = {"frequency_hz": HZ}
    for pair, g in responses(HZ).items():
        columns[f"{pair} re"], columns[f"{pair} im"] = g.real, g.imag
    rows = np.column_stack(list(columns.values()))
    path.write_text(",".join(columns) + "\n" + "\n".join(",".join(f"{v:.17g}" for v in row) for row in rows) + "\n")
    return path


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


@pytest.fixture(scope="module")
def fitted(tmp_path_factory) -> tuple[Path, Path, Result]:
    folder = tmp_path_factory.mktemp("frf")
    table = write_frf(folder / "frf.csv")
    done = run("fit", str(table), "--frequency", "--inputs", "force", "--outputs", "disp,accel", "--nmax", "6",
               "--out", str(folder / "run" / "model.json"), "--report", str(folder / "run" / "report"))
    assert done.exit_code == 0, done.output
    return table, folder / "run", done


def test_the_named_pairs_give_the_model_and_its_modes(fitted):
    _, run_folder, done = fitted
    model = moli.load_model(run_folder / "model.json")
    assert isinstance(model, moli.ContinuousModel)
    assert model.output_names == ("disp", "accel") and model.input_names == ("force",)     # vel left out
    found = moli.modes(model)
    # noise-free lines: the fit recovers the system to round-off (docs/frequency.md: 1e-8 on exact data);
    # 1e-6 leaves room for the refinement's stopping rule
    np.testing.assert_allclose([mode.natural_frequency for mode in found], NATURAL, rtol=1e-6)
    np.testing.assert_allclose([mode.damping for mode in found], DAMPING, rtol=1e-6)
    assert "order 4 selected by the paired rule" in done.stdout
    assert "4.0000" in done.stdout and "30.0000" in done.stdout and "0.6366" in done.stdout   # 4 / 2 pi Hz


def test_the_model_file_records_options_source_and_warnings(fitted):
    table, run_folder, _ = fitted
    info = json.loads((run_folder / "model.json").read_text())["info"]
    assert info["options"]["nmax"] == 6 and info["options"]["time"] == "continuous"
    assert info["data"]["file_sha256"] == file_sha256(table) and info["data"]["source"] == str(table)
    assert info["data"]["lines"] == HZ.size and info["data"]["outputs"] == ["disp", "accel"]
    assert any("real and imaginary parts" in message for message in info["warnings"])


def test_info_describes_the_model_without_an_input_hold_it_never_had(fitted):
    # a model of an FRF saw no samples: "inputs between samples" would say nothing true of it
    _, run_folder, _ = fitted
    shown = run("info", str(run_folder / "model.json"))
    assert shown.exit_code == 0 and "continuous-time state-space model: n = 4" in shown.output
    assert "inputs between samples" not in shown.output


def test_the_saved_options_rerun_the_fit(fitted, tmp_path):
    table, run_folder, _ = fitted
    done = run("fit", str(table), "--frequency", "--outputs", "disp,accel", "--options", str(run_folder / "model.json"),
               "--out", str(tmp_path / "again.json"))
    assert done.exit_code == 0, done.output
    assert moli.load_model(tmp_path / "again.json").n == 4


def test_the_report_has_every_section(fitted):
    _, run_folder, _ = fitted
    page = (run_folder / "report" / "report.html").read_text()
    for section in ("SHA-256 of the input file", "<h2>Selected model</h2>", "<h2>Warnings</h2>", "<h3>Modes",
                    "natural frequency (rad/s)", "<h2>Orders tried</h2>", "Stabilization diagram", "MAC",
                    "relative to the data", "<h2>Options</h2>"):
        assert section in page, section
    for figure in ("magnitude", "phase", "error", "stabilization"):
        assert (run_folder / "report" / f"{figure}.png").exists(), figure


@pytest.mark.parametrize("flags", [["--validation", "0.2"], ["--seed", "3"], ["--continuous"], ["--x0", "estimate"],
                                   ["--all-lists"], ["--preset", "fast"], ["--closed-loop", "open"],
                                   ["--sheet", "1"], ["--outliers", "remove"]])
def test_a_flag_of_time_records_is_one_error_line_before_any_work(flags, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_frf(tmp_path / "frf.csv")
    done = run("fit", "frf.csv", "--frequency", *flags)
    assert done.exit_code == 2
    assert done.stderr.splitlines() == [done.stderr.strip()] and done.stderr.startswith("moli: error: ")
    assert f"{flags[0]} does not apply to --frequency" in done.stderr
    assert not (tmp_path / "moli-fit-frf").exists()


@pytest.mark.parametrize(("flags", "said"), [
    (["--outputs", "disp,strain"], "--outputs disp,strain: no channel strain in frf.csv, whose pair columns name "
                                   "outputs disp, vel, accel"),
    (["--inputs", "force,force"], "--inputs force,force: each channel once"),
])
def test_a_channel_the_file_lacks_is_named(flags, said, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_frf(tmp_path / "frf.csv")
    done = run("fit", "frf.csv", "--frequency", *flags)
    assert done.exit_code == 2
    assert done.stderr.splitlines()[-1].startswith(f"moli: error: {said}")


def test_ctrl_c_during_the_report_keeps_the_model_and_exits_3(tmp_path, monkeypatch):
    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    write_frf(tmp_path / "frf.csv")
    monkeypatch.setattr(frequency_fit, "write_frequency_report", interrupt)
    done = run("fit", "frf.csv", "--frequency", "--order", "4")
    assert done.exit_code == 3, done.stderr
    assert done.stderr.splitlines()[-1] == "moli: interrupted after writing moli-fit-frf/model.json"
    assert moli.load_model(tmp_path / "moli-fit-frf" / "model.json").n == 4


def test_ctrl_c_during_the_fit_writes_nothing_and_exits_130(tmp_path, monkeypatch):
    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.chdir(tmp_path)
    write_frf(tmp_path / "frf.csv")
    monkeypatch.setattr(frequency_fit, "identify", interrupt)
    done = run("fit", "frf.csv", "--frequency")
    assert done.exit_code == 130 and done.stderr.splitlines()[-1] == "moli: interrupted"
    assert not (tmp_path / "moli-fit-frf" / "model.json").exists()


def test_the_report_draws_the_data_s_standard_deviation_where_given(tmp_path):
    g = responses(HZ)["disp/force"]
    rng = np.random.default_rng(0)
    std = 0.02 * np.abs(g)
    noise = std * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape)) / np.sqrt(2)
    data = moli.FrequencyData(HZ, g + noise, unit="Hz", variance=std**2)
    result = moli.identify(data, order=4)
    page = html.unescape(write_frequency_report(result, data, tmp_path).read_text())
    assert "the data's standard deviation per line" in page
    assert "shaded: the model's pointwise 95 % band" in page          # the refined model's covariance


def test_the_report_draws_the_data_s_coherence_under_the_phase_where_given(tmp_path):
    g = responses(HZ)["disp/force"]
    coherence = np.clip(np.abs(g) / np.abs(g).max(), 0.05, 1.0)       # any values in [0, 1]
    with_coherence = moli.FrequencyData(HZ, g, unit="Hz", coherence=coherence)
    result = moli.identify(with_coherence, order=4)
    page = html.unescape(write_frequency_report(result, with_coherence, tmp_path / "with").read_text())
    assert (tmp_path / "with" / "coherence.png").is_file() and "magnitude-squared coherence on each line" in page
    assert page.index('alt="phase"') < page.index('alt="coherence"') < page.index('alt="error"')
    plain = moli.FrequencyData(HZ, g, unit="Hz")
    page = write_frequency_report(moli.identify(plain, order=4), plain, tmp_path / "without").read_text()
    assert not (tmp_path / "without" / "coherence.png").exists() and "coherence on each line" not in page


def write_coherent_frf(path: Path) -> Path:
    """The responses of :func:`responses` with a coherence column of 0.9 per pair."""
    columns = {"frequency_hz": HZ}
    for pair, g in responses(HZ).items():
        columns[f"{pair} re"], columns[f"{pair} im"], columns[f"{pair} coh"] = g.real, g.imag, np.full(HZ.size, 0.9)
    rows = np.column_stack(list(columns.values()))
    path.write_text(",".join(columns) + "\n" + "\n".join(",".join(f"{v:.17g}" for v in row) for row in rows) + "\n")
    return path


def test_coherence_columns_reach_the_report_of_the_command(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_coherent_frf(Path("frf.csv"))
    done = run("fit", "frf.csv", "--frequency", "--outputs", "accel", "--nmax", "4")
    assert done.exit_code == 0, done.output
    assert Path("moli-fit-frf/report/coherence.png").is_file()


def test_averages_turn_the_coherence_into_the_lines_variance(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_coherent_frf(Path("frf.csv"))
    done = run("fit", "frf.csv", "--frequency", "--outputs", "accel", "--nmax", "4", "--averages", "16")
    assert done.exit_code == 0, done.output
    said = " ".join(json.loads(Path("moli-fit-frf/model.json").read_text())["info"]["warnings"])
    assert "the variance from it and 16 averages" in said
    # the same lines read in Python with the same averages carry the variance (1 - 0.9) |G|^2 / (16 x 0.9)
    with pytest.warns(moli.FrequencyConventionWarning, match="16 averages"):
        data = moli.read_frequency_data("frf.csv", averages=16)
    np.testing.assert_allclose(data.variance, 0.1 * np.abs(data.G) ** 2 / (16 * 0.9), rtol=1e-12)


@pytest.mark.parametrize(("frequency", "said"), [
    (True, "averages turn the 'coh' columns into variances"),
    (False, "--averages applies to --frequency"),
])
def test_averages_without_a_coherence_to_turn_are_one_error_line(frequency, said, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_frf(tmp_path / "frf.csv")
    done = run("fit", "frf.csv", *(["--frequency"] if frequency else ["--inputs", "force"]), "--averages", "8")
    assert done.exit_code == 2
    assert done.stderr.splitlines() == [done.stderr.strip()] and said in done.stderr
    assert not (tmp_path / "moli-fit-frf").exists()
