"""Quickstart: identify the built-in plant from Python, check it, save it, report it.

Usage::

    python examples/quickstart.py [OUTDIR]

Writes ``model.json`` and ``report/`` (``report.html`` and its PNG figures) to OUTDIR
(default ``quickstart-output``) and prints the greedy path and the validation scores.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import moli
from moli.app.report import write_report


def main(out: Path) -> None:
    data = moli.example_data(N=800, seed=0)  # 3 inputs, 3 outputs, 10 % output noise
    estimation, validation = data.split(0.5)
    result = moli.identify(estimation, validation, nmax=6)
    print(result.summary())

    model = result.model
    print(model, "poles:", np.round(np.sort(np.abs(model.poles())), 3))
    scores = moli.compare(model, validation)  # simulation from the zero state
    for name, v in zip(validation.output_names, scores.vaf):
        print(f"validation VAF {name}: {v:.1f} %")

    out.mkdir(parents=True, exist_ok=True)
    model.save(out / "model.json")
    reloaded = moli.load_model(out / "model.json")
    assert np.array_equal(reloaded.A, model.A)  # JSON keeps every digit of a float
    print("report:", write_report(result, out / "report"))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("quickstart-output"))
    main(parser.parse_args().out)
