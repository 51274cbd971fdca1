"""identify_many: every record identified as identify would, in order, failures kept apart.

The Dask LocalCluster runs are in tests/fleets/test_dask_cluster.py.
"""

from __future__ import annotations

import concurrent.futures
import sys
from pathlib import Path

import numpy as np
import pytest

import moli
from moli.errors import DataError, OptionError
from moli.fleets.records import FleetEntry, FleetResult, identify_many

OPTIONS = moli.IdentifyOptions(nmax=4)  # the path 3, 4: a real search, fast
NAMES = (("u1", "u2", "u3"), ("y1", "y2", "y3"))
READ = {"inputs": list(NAMES[0]), "outputs": list(NAMES[1])}


def records(count: int = 3) -> dict[str, moli.IOData]:
    return {f"loop{k}": moli.example_data(N=400, seed=k) for k in range(count)}


def assert_same_entries(first: FleetResult, second: FleetResult) -> None:
    """Bit for bit: names, errors, warnings, every path step's scores and the models."""
    assert [e.name for e in first] == [e.name for e in second]
    for a, b in zip(first, second):
        assert (a.error, a.fit) == (b.error, b.fit), a.name
        assert a.warnings == b.warnings, a.name
        if a.result is None:
            assert b.result is None
            continue
        assert a.result.selected_index == b.result.selected_index
        for step_a, step_b in zip(a.result.path, b.result.path, strict=True):
            assert (step_a.indices, step_a.J) == (step_b.indices, step_b.J)
            np.testing.assert_array_equal(step_a.vaf, step_b.vaf)
        for name in "ABCD":
            np.testing.assert_array_equal(getattr(a.result.model, name), getattr(b.result.model, name))


@pytest.fixture(scope="module")
def serial() -> FleetResult:
    return identify_many(records(), OPTIONS, n_jobs=1, progress=False)


def test_each_entry_is_the_identify_result_in_input_order(serial):
    assert [e.name for e in serial] == ["loop0", "loop1", "loop2"]
    assert serial.backend == "this process" and not serial.failures
    for entry, data in zip(serial, records().values()):
        alone = moli.identify(data, options=OPTIONS)  # the independent truth: one call each
        np.testing.assert_array_equal(entry.result.model.A, alone.model.A)
        assert entry.result.selected.order == alone.selected.order
        # the fit is the mean validation NRMSE fit of the selected model
        fit = np.mean(moli.compare(alone.model, alone.validation, OPTIONS.x0).fit)
        assert entry.fit == fit and entry.seconds > 0
    assert serial["loop1"] is serial[1]


@pytest.mark.parametrize("executor", ["processes", "executor", "threading"])
def test_every_local_backend_gives_the_serial_results(serial, executor):
    if executor == "executor":  # any concurrent.futures executor (processes: the test below)
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            other = identify_many(records(), OPTIONS, executor=pool, progress=False)
        assert other.backend == "ThreadPoolExecutor"
    elif executor == "processes":
        other = identify_many(records(), OPTIONS, n_jobs=2, progress=False)
        assert other.backend == "2 processes"
    else:
        other = identify_many(records(), OPTIONS, executor="threading", n_jobs=2, progress=False)
        assert other.backend == "joblib threading, 2 workers"
    assert_same_entries(serial, other)


def test_local_processes_need_no_joblib(serial, monkeypatch):
    monkeypatch.setitem(sys.modules, "joblib", None)  # as if the distributed extra were absent
    other = identify_many(records(), OPTIONS, n_jobs=2, progress=False)
    assert other.backend == "2 processes"
    assert_same_entries(serial, other)


def corrupt_fleet(folder: Path) -> list[Path]:
    """Three good CSV records between broken files of several kinds."""
    good = []
    for name, data in records().items():
        good.append(folder / f"{name}.csv")
        moli.to_dataframe(data).to_csv(good[-1])
    text = good[0].read_text().splitlines()
    cells = text[50].split(",")  # file line 51: time, y1, y2, y3, u1, ...
    cells[4] = "oops"
    bad = {
        "cell.csv": "\n".join(text[:50] + [",".join(cells)] + text[51:]),
        "empty.csv": "",
        "short.csv": "\n".join(text[:6]),
        "columns.csv": text[0].replace("y3", "flow") + "\n" + "\n".join(text[1:]),
        "garbage.npz": "not a zip archive",
    }
    for name, content in bad.items():
        (folder / name).write_text(content)
    paths = [good[0], folder / "cell.csv", folder / "empty.csv", good[1], folder / "short.csv",
             folder / "columns.csv", folder / "garbage.npz", folder / "absent.csv", good[2]]
    return paths


def test_corrupt_files_fail_alone_under_their_names(tmp_path, serial):
    paths = corrupt_fleet(tmp_path)
    seen: list[FleetEntry] = []
    fleet = identify_many(paths, OPTIONS, n_jobs=2, read_options=READ, progress=seen.append)
    assert [e.name for e in fleet] == [p.stem for p in paths]
    assert sorted(e.name for e in seen) == sorted(p.stem for p in paths)  # each reported once
    errors = {e.name: e.error for e in fleet.failures}
    assert set(errors) == {"cell", "empty", "short", "columns", "garbage", "absent"}
    assert "line 51, column 'u1': 'oops' is not a number" in errors["cell"]
    assert "is empty" in errors["empty"] and "too few samples" in errors["short"]
    assert "no column 'y3'" in errors["columns"] and "cannot read" in errors["garbage"]
    assert errors["absent"].startswith("DataError: no data file at")
    # the good records between them: the serial in-memory results, bit for bit (the CSV
    # round trip of to_dataframe keeps every float64 digit)
    good = FleetResult([fleet["loop0"], fleet["loop1"], fleet["loop2"]], "", 0.0)
    assert_same_entries(serial, good)
    frame = fleet.to_dataframe()
    assert list(frame.columns) == ["name", "order", "fit", "vaf", "seconds", "error"]
    assert frame["order"].isna().sum() == 6 and frame["fit"].notna().sum() == 3
    assert frame.set_index("name").loc["loop1", "fit"] == fleet["loop1"].fit


def test_pairs_paths_and_records_mix_and_inputs_are_untouched(tmp_path):
    data = moli.example_data(N=600, seed=4)
    est, val = data.split(400)
    path = tmp_path / "val.npz"
    np.savez(path, y=val.y, u=val.u)
    y_before = data.y.copy()
    fleet = identify_many([(est, path), data], OPTIONS, n_jobs=1, progress=False)
    assert [e.name for e in fleet] == ["record-0", "record-1"]
    # a pair is an estimation record and its validation record, as in identify
    paired = moli.identify(est, moli.IOData(val.y, val.u), OPTIONS)
    np.testing.assert_array_equal(fleet[0].result.model.A, paired.model.A)
    assert fleet[0].result.validation_source == "given"
    assert fleet[1].result.validation_source.startswith("held out")
    np.testing.assert_array_equal(data.y, y_before)


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: identify_many(moli.example_data(N=50)), DataError, "datasets must be a list or a mapping"),
        (lambda: identify_many([moli.example_data(N=50), 3]), DataError, "datasets[1] must be an IOData"),
        (lambda: identify_many({"a": (1, 2)}), DataError, "datasets['a'] must be"),
        (lambda: identify_many(["x/a.csv", "y/a.csv"]), DataError, "both named 'a'"),
        (lambda: identify_many([moli.example_data(N=50)], options={"nmax": 3}), OptionError, "options must be an IdentifyOptions"),
        (lambda: identify_many([moli.example_data(N=50)], n_jobs=0), OptionError, "n_jobs must be a positive integer"),
        (lambda: identify_many([moli.example_data(N=50)], executor=42), OptionError, "executor must be None"),
        (lambda: identify_many([moli.example_data(N=50)], executor="nonesuch"), OptionError, "executor:"),
        (lambda: identify_many([moli.example_data(N=50)], read_options={"columns": 1}), OptionError, "read_options:"),
        (lambda: identify_many([moli.example_data(N=50)], progress="yes"), OptionError, "progress must be"),
    ],
)
def test_bad_arguments_are_named_before_any_work(call, error, message):
    with pytest.raises(error) as caught:
        call()
    assert message in str(caught.value)


def test_n_jobs_with_an_executor_is_refused():
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        with pytest.raises(OptionError, match="leave n_jobs out"):
            identify_many(records(1), executor=pool, n_jobs=2)


def test_progress_bar_counts_records_and_failures(capsys):
    fleet = {**records(1), "broken": moli.IOData(np.zeros(5), np.ones(5))}
    result = identify_many(fleet, OPTIONS, n_jobs=1)
    assert "2/2" in capsys.readouterr().err and len(result.failures) == 1


def test_ray_through_joblib_gives_the_serial_results(serial):
    ray = pytest.importorskip("ray", reason="the Ray backend test needs ray (not in the test extra)")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        other = identify_many(records(), OPTIONS, executor="ray", n_jobs=2, progress=False)
    finally:
        ray.shutdown()
    assert other.backend == "joblib ray, 2 workers"
    assert_same_entries(serial, other)


def test_relative_paths_are_read_from_the_callers_folder_by_reused_workers(tmp_path, monkeypatch):
    """Local workers outlive one call and keep the folder they started in."""
    counts = {"a": 300, "b": 360}
    for folder, N in counts.items():
        (tmp_path / folder).mkdir()
        for name in ("one", "two"):
            moli.to_dataframe(moli.example_data(N=N, seed=1)).to_csv(tmp_path / folder / f"{name}.csv")
    for folder, N in counts.items():
        monkeypatch.chdir(tmp_path / folder)
        fleet = identify_many(["one.csv", "two.csv"], OPTIONS, n_jobs=2, read_options=READ, progress=False)
        for entry in fleet:
            assert entry.result is not None, entry.error
            assert entry.result.estimation.N + entry.result.validation.N == N, entry.name
