"""What the install lines promise: the license, and python-control in the cli extra."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

tomllib = pytest.importorskip("tomllib")  # Python 3.11+


@pytest.fixture(scope="module")
def project() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def test_an_mit_license_file_exists_and_pyproject_declares_it(project):
    text = (REPO / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Permission is hereby granted, free of charge" in text
    assert project["license"] == {"text": "MIT"}


def test_the_cli_extra_installs_python_control_and_the_readers(project):
    extras = project["optional-dependencies"]
    names = {re.split(r"[<>=\[]", req)[0] for req in extras["cli"]}
    assert {"click", "tqdm", "matplotlib", "control"} <= names
    assert "moli[data]" in extras["cli"]


@pytest.mark.parametrize("page", ["README.md", "docs/cli.md"])
def test_the_install_line_names_the_cli_extra_and_what_it_brings(page):
    text = (REPO / page).read_text()
    line = next(line for line in text.splitlines() if "pip install -e '.[cli]'" in line)
    assert "python-control" in line
