"""On a real Dask LocalCluster (2 worker processes, one thread each): a fleet, a long
record reduced over its stored chunks, and ``moli fit-many --scheduler``.

Every result is compared with the same computation in this process.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import moli
from moli.data.chunks import list_chunks
from moli.errors import DataError
from moli.fleets.chunk_reduction import estimate_chunks
from moli.streaming.chunked import ChunkedEstimator

from systems_util import plant_record

distributed = pytest.importorskip(
    "distributed", reason="the Dask cluster tests need dask[distributed]: pip install 'moli[distributed]'"
)
pa = pytest.importorskip("pyarrow", reason="the long-record tests store it in Parquet (pyarrow)")
pq = pytest.importorskip("pyarrow.parquet", reason="the long-record tests store it in Parquet (pyarrow)")

INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)
OPTIONS = moli.IdentifyOptions(nmax=4)


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, scheduler_port=0) as cluster:
        with distributed.Client(cluster, timeout="30s") as connected:
            connected.wait_for_workers(2, timeout=60)
            yield connected


def test_a_fleet_on_the_cluster_equals_the_fleet_in_this_process(client):
    fleet = {f"loop{k}": moli.example_data(N=400, seed=k) for k in range(4)}
    fleet["short"] = moli.IOData(np.zeros((8, 3)), np.ones((8, 3)))  # too short to identify
    here = moli.identify_many(fleet, OPTIONS, n_jobs=1, progress=False)
    there = moli.identify_many(fleet, OPTIONS, executor=client, progress=False)
    assert there.backend.startswith("dask, tcp://")
    assert [e.name for e in there] == list(fleet)
    assert [e.ok for e in there] == [True] * 4 + [False]
    assert there["short"].error == here["short"].error
    for a, b in zip(here, there):
        assert (a.fit, a.warnings) == (b.fit, b.warnings)
        if a.ok:  # bit for bit: the same arithmetic on another machine's process
            for name in "ABCD":
                np.testing.assert_array_equal(getattr(a.result.model, name), getattr(b.result.model, name))
            assert [s.J for s in a.result.path] == [s.J for s in b.result.path]


def long_record(folder: Path, kind: str) -> tuple[list, ChunkedEstimator]:
    """A 60 000-sample 3x3 record stored in pieces of 7 000, and the single-process estimate."""
    y, u, _ = plant_record(60_000, noise=0.1, seed=11)
    table = {**{f"y{j + 1}": y[:, j] for j in range(3)}, **{f"u{j + 1}": u[:, j] for j in range(3)}}
    if kind == "parquet":
        path = folder / "long.parquet"
        pq.write_table(pa.table(table), path, row_group_size=7_000)
    else:
        zarr = pytest.importorskip("zarr", reason="Zarr records need zarr")
        path = folder / "long.zarr"
        group = zarr.open_group(str(path), mode="w")
        for name, values in table.items():
            group.create_array(name, shape=values.shape, chunks=(7_000,), dtype=float)[:] = values
    chunks = list_chunks(path, ["u1", "u2", "u3"], ["y1", "y2", "y3"])
    reference = ChunkedEstimator(INDICES, ALPHA, 3)
    for chunk in chunks:
        reference.add(*chunk())
    return chunks, reference


@pytest.mark.parametrize("kind, read_once", [("parquet", False), ("zarr", False), ("parquet", True)])
def test_long_record_reduction_on_the_cluster_equals_the_single_process_estimate(client, tmp_path, kind,
                                                                                   read_once):
    chunks, reference = long_record(tmp_path, kind)
    assert len(chunks) == 9  # 8 full pieces and a short last one: the tree is not balanced
    reduced = estimate_chunks(chunks, INDICES, ALPHA, 3, client=client, read_once=read_once)
    assert reduced.samples == reference.samples == 60_000
    expected, model = reference.model(), reduced.model()
    for name in "ABC":
        # QR in another order, boundary states from the scan: round-off apart; the
        # problem's condition is ~1e3, so 1e-10 relative is a wide margin
        gap = np.max(np.abs(getattr(model, name) - getattr(expected, name)))
        assert gap <= 1e-10 * np.max(np.abs(getattr(expected, name))), name
    for mine, theirs in zip(reduced.filter_states(), reference.filter_states()):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12)


def test_a_chunk_that_fails_on_a_worker_raises_here(client, tmp_path):
    chunks, _ = long_record(tmp_path, "parquet")
    (tmp_path / "long.parquet").write_text("replaced after listing")
    with pytest.raises(DataError, match=r"cannot read samples \d+:\d+ of .*long.parquet"):
        estimate_chunks(chunks, INDICES, ALPHA, 3, client=client)


def test_fit_many_on_a_scheduler_writes_the_local_models(client, tmp_path):
    from click.testing import CliRunner

    from moli.app import cli

    paths = []
    for k in range(3):
        paths.append(tmp_path / "plant" / f"loop{k}.csv")
        paths[-1].parent.mkdir(exist_ok=True)
        moli.to_dataframe(moli.example_data(N=400, seed=k)).to_csv(paths[-1])
    address = client.scheduler.address
    done = CliRunner().invoke(cli.cli, [
        "fit-many", str(tmp_path / "plant" / "*.csv"), "--inputs", "u1,u2,u3", "--outputs", "y1,y2,y3",
        "--nmax", "4", "--scheduler", address, "--out", str(tmp_path / "models")])
    assert done.exit_code == 0, done.output + done.stderr
    assert f"on dask, {address}" in done.output
    read = {"inputs": ["u1", "u2", "u3"], "outputs": ["y1", "y2", "y3"]}
    here = moli.identify_many(paths, OPTIONS, n_jobs=1, read_options=read, progress=False)
    for entry in here:
        saved = moli.load_model(tmp_path / "models" / f"{entry.name}.json")
        np.testing.assert_array_equal(saved.A, entry.result.model.A)


def _sampling(dask_worker) -> tuple[bool, float]:
    callbacks = dask_worker.periodic_callbacks
    return callbacks["profile"].is_running(), callbacks["tick"].callback_time


def test_a_fleet_runs_without_the_workers_profiler_and_puts_it_back(client):
    default = set(client.run(_sampling).values())
    assert default == {(True, 20.0)}  # Dask's defaults: the test means nothing otherwise
    during = []
    fleet = {f"loop{k}": moli.example_data(N=300, seed=k) for k in range(2)}
    moli.identify_many(fleet, moli.IdentifyOptions(nmax=2), executor=client,
                       progress=lambda entry: during.append(set(client.run(_sampling).values())))
    assert during == [{(False, 1000.0)}] * 2
    assert set(client.run(_sampling).values()) == default


def test_overlapping_quiet_blocks_restore_the_workers_when_the_last_ends(client):
    from moli.fleets.dask_workers import quiet_workers

    with quiet_workers(client):
        with quiet_workers(client):
            pass
        assert set(client.run(_sampling).values()) == {(False, 1000.0)}
    assert set(client.run(_sampling).values()) == {(True, 20.0)}


def test_workers_started_under_the_config_have_no_profiler():
    import dask

    with dask.config.set(moli.fleets.dask_worker_config()), \
            distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as connected:
        assert set(connected.run(lambda dask_worker: "profile" in dask_worker.periodic_callbacks).values()) == {False}
