"""Tests of the DaISy loaders. No test touches the network."""

from __future__ import annotations

import gzip
import hashlib
import io
import os
import urllib.error
from pathlib import Path

import numpy as np
import pytest

from moli.data import daisy as datasets, daisy_catalog
from moli.data import IOData
from moli.errors import DataError, MoliError, OptionError

REPO_ROOT = Path(__file__).resolve().parents[2]


def _shared_dir() -> Path:
    env = os.environ.get("MOLI_DATA_DIR")
    return Path(env) if env else REPO_ROOT.parent / "shared" / "data" / "daisy"


SHARED = _shared_dir()
needs_shared = pytest.mark.skipif(
    not (SHARED / "evaporator.dat").is_file(),
    reason=f"DaISy files not found in {SHARED} (set MOLI_DATA_DIR to a folder holding them)",
)


@pytest.fixture(autouse=True)
def offline(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """Forbid downloads and point the cache at an empty temporary folder."""

    def refuse(url: str, timeout: float) -> io.BytesIO:
        raise urllib.error.URLError(f"network disabled in tests ({url})")

    monkeypatch.setattr(datasets, "_open_url", refuse)
    monkeypatch.delenv("MOLI_DATA_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("MOLI_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "daisy"


# name: (N, m, p, Ts, first output name), from the DaISy data sheet
SHEET = {
    "ballbeam": (1000, 1, 1, 0.1, "ball position"),
    "CD_player_arm": (2048, 2, 2, 1.0, "tracking 1"),
    "cstr": (7500, 1, 2, 0.1, "concentration Ca"),
    "destill": (90, 5, 3, 15.0, "top ethane"),
    "dryer": (1000, 1, 1, 1.0, "outlet temperature"),
    "dryer2": (867, 3, 3, 10.0, "dry bulb temperature"),
    "evaporator": (6305, 3, 3, 1.0, "dry matter content"),
    "exchanger": (4000, 1, 1, 1.0, "outlet temperature"),
    "flutter": (1024, 1, 1, 1.0, "y"),
    "glassfurnace": (1247, 3, 6, 1.0, "temperature 1"),
    "heating_system": (801, 1, 1, 2.0, "plate temperature"),
    "pHdata": (2001, 2, 1, 10.0, "pH"),
    "robot_arm": (1024, 1, 1, 1.0, "arm acceleration"),
    "thermic_res_wall": (1680, 2, 1, 1.0, "heat flow density"),
}


@needs_shared
@pytest.mark.parametrize("name", sorted(SHEET))
def test_shapes_names_and_period(name: str) -> None:
    N, m, p, Ts, first_output = SHEET[name]
    data = datasets.load_daisy(name, SHARED)
    assert isinstance(data, IOData)
    assert (data.N, data.m, data.p, data.Ts) == (N, m, p, Ts)
    assert data.output_names[0] == first_output


@needs_shared
@pytest.mark.parametrize("info", datasets.list_daisy()[:15], ids=lambda i: i.name)
def test_registry_checksums_match_the_shared_files(info: datasets.DaisyInfo) -> None:
    digest = hashlib.sha256((SHARED / f"{info.name}.dat").read_bytes()).hexdigest()
    assert digest == info.sha256


@needs_shared
def test_known_values_and_dropped_time_columns() -> None:
    # Values typed from the files; loadtxt parses them exactly, 1e-12 only covers the
    # decimal-to-binary rounding of the literals below.
    evap = datasets.load_daisy("evaporator", SHARED)
    np.testing.assert_allclose(evap.u[0], [1.0112465, -0.93502246, 1.0197526], rtol=1e-12)
    np.testing.assert_allclose(evap.y[0], [-0.31526751, 0.18242489, -0.062869153], rtol=1e-12)
    cstr = datasets.load_daisy("cstr", SHARED)  # column 0 (time in min) is dropped
    np.testing.assert_allclose(cstr.u[0], [101.7373091101724], rtol=1e-12)
    np.testing.assert_allclose(cstr.y[0], [0.1, 438.54], rtol=1e-12)
    heat = datasets.load_daisy("heating_system", SHARED)  # CRLF file, time column dropped
    assert (heat.u[0, 0], heat.y[0, 0]) == (9.0, 129.32)
    assert set(np.unique(heat.u)) == {3.0, 4.0, 6.0, 7.0, 8.0, 9.0}


@needs_shared
def test_destill_noise_levels() -> None:
    clean = datasets.load_daisy("destill", SHARED)
    assert not np.any(np.diff(clean.u[:, 0]) == 1.0), "the sample counter leaked into u"
    for level in (10, 20, 30):
        noisy = datasets.load_daisy("destill", SHARED, noise=level)
        # The sheet measured std(noisy - clean) / std(clean) at about level/100 on
        # every channel; with 90 samples the estimate scatters by a few percent, so
        # +-0.05 separates the levels without being fragile.
        for noisy_sig, clean_sig in ((noisy.u, clean.u), (noisy.y, clean.y)):
            ratio = np.std(noisy_sig - clean_sig, axis=0) / np.std(clean_sig, axis=0)
            np.testing.assert_allclose(ratio, level / 100, atol=0.05)


@needs_shared
def test_distill2_step_responses() -> None:
    resp = datasets.load_daisy("distill2", SHARED, step=3)
    assert (resp.N, resp.m, resp.p, resp.Ts) == (251, 3, 2, 10.0)
    np.testing.assert_array_equal(resp.u, np.tile([0.0, 0.0, 1.0], (251, 1)))
    np.testing.assert_allclose(resp.y[0], [1.1997313e5, 1.4345700], rtol=1e-12)
    first = datasets.load_daisy("distill2", SHARED, step=1)
    np.testing.assert_allclose(first.y[0], [2.3994627e4, 2.8691400e-1], rtol=1e-12)


def test_list_daisy_covers_every_set() -> None:
    info = {d.name: d for d in datasets.list_daisy()}
    assert set(SHEET) | {"distill2", "steamgen", "winding", "powerplant"} == set(info)
    steam = info["steamgen"]
    assert (steam.p, steam.m, steam.N, steam.Ts) == (4, 4, 9600, 3.0)
    assert (info["winding"].p, info["winding"].m, info["winding"].Ts) == (2, 5, 0.1)
    assert (info["powerplant"].p, info["powerplant"].m, info["powerplant"].Ts) == (3, 5, 1228.8)
    assert not info["evaporator"].Ts_stated and info["evaporator"].Ts == 1.0
    assert info["cstr"].Ts_unit == "min"
    assert info["evaporator"].url.startswith("https://ftp.esat.kuleuven.be/pub/SISTA/data/")


@pytest.mark.parametrize(
    ("name", "options", "message"),
    [
        ("evaporater", {}, "known: "),
        ("evaporator", {"noise": 10}, "noise applies only"),
        ("destill", {"noise": 15}, "noise in (0, 10, 20, 30)"),
        ("distill2", {}, "step in (1, 2, 3)"),
        ("cstr", {"step": 1}, "step applies only"),
    ],
)
def test_bad_options_raise_before_any_file_access(name: str, options: dict, message: str) -> None:
    with pytest.raises(OptionError, match=message.replace("(", r"\(").replace(")", r"\)")):
        datasets.load_daisy(name, **options)


def test_offline_download_fails_cleanly(offline: Path, tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(datasets.DatasetUnavailableError) as caught:
        datasets.load_daisy("evaporator", empty)
    text = str(caught.value)
    assert datasets.daisy_url("evaporator") in text
    assert str(empty) in text and str(offline) in text
    assert isinstance(caught.value, MoliError)
    assert not offline.exists() or not any(offline.iterdir())


def test_unreachable_server_fails_cleanly(monkeypatch: pytest.MonkeyPatch) -> None:
    # Real urllib against the discard port of the loopback interface: refused at once,
    # and nothing leaves the machine.
    monkeypatch.setattr(datasets, "_open_url", datasets.urllib.request.urlopen)
    monkeypatch.setattr(datasets, "DAISY_BASE_URL", "http://127.0.0.1:9")
    monkeypatch.setattr(datasets, "DOWNLOAD_TIMEOUT", 2.0)
    with pytest.raises(datasets.DatasetUnavailableError, match="http://127.0.0.1:9/"):
        datasets.load_daisy("ballbeam")


TINY = b"1 10 100\n2 20 200\n3 30 300\n"


@pytest.fixture
def tiny(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Register a 3x3 set 'tiny' (time, u, y) and serve it gzipped; return the URLs fetched."""
    spec = daisy_catalog.DaisySpec(
        "thermic", "test set", (3, 3), (1,), (2,), ("u",), ("y",), 0.5,
        sha256=hashlib.sha256(TINY).hexdigest(),
    )
    monkeypatch.setitem(daisy_catalog.SPECS, "tiny", spec)
    fetched: list[str] = []

    def serve(url: str, timeout: float) -> io.BytesIO:
        fetched.append(url)
        return io.BytesIO(gzip.compress(TINY))

    monkeypatch.setattr(datasets, "_open_url", serve)
    return fetched


def test_download_is_cached_and_reused(tiny: list[str], offline: Path) -> None:
    data = datasets.load_daisy("tiny")
    np.testing.assert_array_equal(data.u.ravel(), [10, 20, 30])
    np.testing.assert_array_equal(data.y.ravel(), [100, 200, 300])
    assert tiny == [datasets.daisy_url("tiny")]
    assert (offline / "tiny.dat").read_bytes() == TINY
    assert [p.name for p in offline.iterdir()] == ["tiny.dat"]  # no temporary file left
    datasets.load_daisy("tiny")
    assert len(tiny) == 1, "the cached copy must be used"


def test_lookup_order(tiny: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first, second = tmp_path / "first", tmp_path / "second"
    for folder, value in ((first, b"7"), (second, b"8")):
        folder.mkdir()
        (folder / "tiny.dat").write_bytes(TINY.replace(b"100", value))
    monkeypatch.setenv("MOLI_DATA_DIR", str(second))
    assert datasets.load_daisy("tiny", first).y[0, 0] == 7.0
    assert datasets.load_daisy("tiny").y[0, 0] == 8.0
    assert tiny == []


def test_checksum_mismatch_raises_and_keeps_nothing(
    tiny: list[str], offline: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    other = gzip.compress(TINY + b"4 40 400\n")
    monkeypatch.setattr(datasets, "_open_url", lambda url, timeout: io.BytesIO(other))
    with pytest.raises(datasets.DatasetChecksumError, match="expected"):
        datasets.load_daisy("tiny")
    assert not (offline / "tiny.dat").exists()


def test_unchecksummed_download_is_checked_for_shape(
    tiny: list[str], offline: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = daisy_catalog.SPECS["tiny"]
    monkeypatch.setitem(daisy_catalog.SPECS, "tiny", daisy_catalog.DaisySpec(
        spec.folder, spec.description, (3, 4), spec.u_cols, spec.y_cols, spec.inputs,
        spec.outputs, spec.Ts))
    with pytest.raises(DataError, match=r"shape \(3, 3\), expected \(3, 4\)"):
        datasets.load_daisy("tiny")
    assert not (offline / "tiny.dat").exists()


def test_corrupt_gzip_is_reported_as_unavailable(
    tiny: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    page = b"<html>moved</html>"
    monkeypatch.setattr(datasets, "_open_url", lambda url, timeout: io.BytesIO(page))
    with pytest.raises(datasets.DatasetUnavailableError, match="tiny.dat.gz"):
        datasets.load_daisy("tiny")


def test_unwritable_cache_is_reported(
    tiny: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("")  # a file where the cache folder should be
    monkeypatch.setenv("MOLI_CACHE_DIR", str(blocker))
    with pytest.raises(datasets.DatasetUnavailableError, match="MOLI_CACHE_DIR"):
        datasets.load_daisy("tiny")


def test_cache_dir_follows_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("MOLI_CACHE_DIR", str(tmp_path))
    assert datasets.cache_dir() == tmp_path / "daisy"
    monkeypatch.delenv("MOLI_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert datasets.cache_dir() == tmp_path / "xdg" / "moli" / "daisy"
