"""Where benchmarks read DaISy files: $MOLI_DATA_DIR, else ../shared/data/daisy beside the repo."""

from __future__ import annotations

import os
from pathlib import Path

import moli
from moli.data.daisy import load_daisy

REPO = Path(__file__).resolve().parents[1]


def daisy_dir() -> Path:
    """The folder holding the DaISy ``.dat`` files."""
    given = os.environ.get("MOLI_DATA_DIR")
    return Path(given) if given else REPO.parent / "shared" / "data" / "daisy"


def load(name: str) -> moli.IOData:
    """A DaISy record read in place (no download)."""
    return load_daisy(name, data_dir=daisy_dir())
