"""Shared fixtures: random test systems and the DaISy data directory."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from threadpoolctl import threadpool_limits

import moli
import moli.data.daisy

REPO = Path(__file__).resolve().parents[1]

# Multi-threaded BLAS on small least-squares problems is slower and erratic on
# shared 2-core machines; the library's own numbers are single-threaded.
threadpool_limits(1)


def daisy_dir() -> Path | None:
    """The DaISy folder: $MOLI_DATA_DIR, else ../shared/data/daisy beside the repo."""
    given = os.environ.get("MOLI_DATA_DIR")
    path = Path(given) if given else REPO.parent / "shared" / "data" / "daisy"
    return path if path.is_dir() else None


def load_shared(name: str) -> moli.IOData:
    """A shipped DaISy record read in place; skips the test when the folder lacks it."""
    folder = daisy_dir()
    if folder is None or not (folder / f"{name}.dat").is_file():
        pytest.skip(f"DaISy {name}.dat not found: set MOLI_DATA_DIR to the DaISy folder")
    return moli.data.daisy.load_daisy(name, data_dir=folder)


@pytest.fixture
def evaporator() -> moli.IOData:
    return load_shared("evaporator")


def _load_script(path: Path):
    """Import a script of the repository (not a package module) by its path."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def twin_rotor_docs():
    """benchmarks/twin_rotor_docs.py, which also loads examples/twin_rotor.py and the seed study."""
    return _load_script(REPO / "benchmarks" / "twin_rotor_docs.py")


@pytest.fixture(scope="session")
def twin_rotor_study(twin_rotor_docs):
    """The study of examples/twin_rotor.py for seed 0: model, LQ and PID, both experiments.

    Shared by the control tests and the doc check, so the closed-loop runs happen once.
    """
    return twin_rotor_docs.example.run_study(0)


@pytest.fixture(scope="session")
def no_coulomb_seed0(twin_rotor_docs):
    """Rig without Coulomb friction or quantisation, its seed-0 record and identification."""
    seeds = twin_rotor_docs.seeds
    rig = seeds.make_rig("no Coulomb")
    return (rig, *seeds.identify_seed(rig, 0))
