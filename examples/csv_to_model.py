"""From a spreadsheet export to a validated model: CSV in, model file and report out.

Usage::

    python examples/csv_to_model.py [OUTDIR]

Writes a CSV export of a simulated test run (``plant.csv``: a time column, three
inputs, three outputs, a text column the reader ignores), then does with the Python
API what this command does::

    moli fit plant.csv --inputs u1,u2,u3 --outputs y1,y2,y3 --validation 0.4 \\
        --nmax 6 --out model.json --report report

and finally checks the saved model on a second, independent test run, as
``moli validate model.json rerun.csv`` would. Everything goes to OUTDIR (default
``csv-output``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import moli
from moli.app.report import write_report


def export_csv(data: moli.IOData, path: Path) -> None:
    """What a process historian or spreadsheet hands over: a header row and one row per sample."""
    frame = moli.to_dataframe(data)
    frame["operator"] = "shift A"
    frame.to_csv(path)


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    export_csv(moli.example_data(N=800, seed=1), out / "plant.csv")
    export_csv(moli.example_data(N=400, seed=2), out / "rerun.csv")

    data = moli.read_data(out / "plant.csv", ["u1", "u2", "u3"], ["y1", "y2", "y3"])
    print("read", data)
    estimation, validation = data.split(0.6)
    result = moli.identify(estimation, validation, nmax=6)
    print(result.summary())
    result.model.save(out / "model.json")
    print("report:", write_report(result, out / "report"))

    model = moli.load_model(out / "model.json")
    rerun = moli.read_data(out / "rerun.csv", model.input_names, model.output_names)
    check = moli.compare(model, rerun)
    for name, v, f in zip(rerun.output_names, check.vaf, check.fit):
        print(f"independent run, {name}: VAF {v:.1f} %, fit {f:.1f} %")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=Path("csv-output"))
    main(parser.parse_args().out)
