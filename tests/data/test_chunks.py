"""list_chunks: the pieces of a Parquet or Zarr record, read back exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from moli.data.chunks import RecordChunk, list_chunks
from moli.errors import DataError

pa = pytest.importorskip("pyarrow", reason="Parquet records need pyarrow")
pq = pytest.importorskip("pyarrow.parquet", reason="Parquet records need pyarrow")

INPUTS, OUTPUTS = ["u1", "u2"], ["y1"]


def columns(N: int = 1000, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"y1": rng.standard_normal(N), "u1": rng.standard_normal(N), "u2": rng.standard_normal(N),
            "note": np.arange(N)}


def write_parquet(path: Path, table: dict[str, np.ndarray], rows: int) -> Path:
    pq.write_table(pa.table(table), path, row_group_size=rows)
    return path


def write_zarr(path: Path, table: dict[str, np.ndarray], rows: int) -> Path:
    zarr = pytest.importorskip("zarr", reason="Zarr records need zarr")
    group = zarr.open_group(str(path), mode="w")
    for name, values in table.items():
        array = group.create_array(name, shape=values.shape, chunks=(rows,), dtype=values.dtype)
        array[:] = values
    return path


def joined(chunks: list[RecordChunk]) -> tuple[np.ndarray, np.ndarray]:
    pieces = [chunk() for chunk in chunks]
    return np.vstack([y for y, _ in pieces]), np.vstack([u for _, u in pieces])


@pytest.mark.parametrize("writer", [write_parquet, write_zarr])
def test_pieces_cover_the_record_in_order_exactly(tmp_path, writer):
    table = columns()
    path = writer(tmp_path / ("rec.parquet" if writer is write_parquet else "rec.zarr"), table, 300)
    chunks = list_chunks(path, INPUTS, OUTPUTS)
    assert [(c.start, c.stop) for c in chunks] == [(0, 300), (300, 600), (600, 900), (900, 1000)]
    y, u = joined(chunks)
    np.testing.assert_array_equal(y[:, 0], table["y1"])
    np.testing.assert_array_equal(u, np.column_stack([table["u1"], table["u2"]]))


def test_a_record_may_span_files_of_both_kinds(tmp_path):
    first, second = columns(500, 1), columns(700, 2)
    paths = [write_parquet(tmp_path / "a.parquet", first, 200), write_zarr(tmp_path / "b.zarr", second, 250)]
    chunks = list_chunks(paths, INPUTS, OUTPUTS)
    assert [c.stop - c.start for c in chunks] == [200, 200, 100, 250, 250, 200]
    y, _ = joined(chunks)
    np.testing.assert_array_equal(y[:, 0], np.concatenate([first["y1"], second["y1"]]))


def test_errors_name_the_file_and_the_problem(tmp_path):
    path = write_parquet(tmp_path / "rec.parquet", columns(), 300)
    with pytest.raises(DataError, match="has no column 'y9'"):
        list_chunks(path, INPUTS, ["y9"])
    with pytest.raises(DataError, match="neither a .parquet file nor a Zarr group"):
        list_chunks(tmp_path / "absent.parquet", INPUTS, OUTPUTS)
    (tmp_path / "rec.csv").write_text("u1,y1\n1,2\n")
    with pytest.raises(DataError, match="neither"):
        list_chunks(tmp_path / "rec.csv", INPUTS, OUTPUTS)
    (tmp_path / "broken.parquet").write_text("not parquet")
    with pytest.raises(DataError, match="cannot read"):
        list_chunks(tmp_path / "broken.parquet", INPUTS, OUTPUTS)
    with pytest.raises(DataError, match="named both as input and as output"):
        list_chunks(path, ["u1"], ["u1"])
    with pytest.raises(DataError, match="at least one"):
        list_chunks([], INPUTS, OUTPUTS)
    uneven = columns()
    uneven["u2"] = uneven["u2"][:900]
    zarr_path = write_zarr(tmp_path / "uneven.zarr", uneven, 300)
    with pytest.raises(DataError, match="1-D arrays of one length"):
        list_chunks(zarr_path, INPUTS, OUTPUTS)


def test_a_piece_that_cannot_be_read_says_which(tmp_path):
    path = write_parquet(tmp_path / "rec.parquet", columns(), 300)
    chunks = list_chunks(path, INPUTS, OUTPUTS)
    path.write_text("overwritten after listing")
    with pytest.raises(DataError, match=r"cannot read samples 300:600 of .*rec.parquet"):
        chunks[1]()
