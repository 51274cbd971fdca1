"""Diagnostics of two identified models, for docs/diagnostics.md: residuals, gain and step bands.

Usage::

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/diagnostics_figures.py [--out docs]

Models: the simulated twin rotor identified as in ``examples/twin_rotor.py`` (seed 0,
estimation on the first 15 s of the 60 s experiment), and the DaISy evaporator with the
default ``identify`` on the paper split (estimation 0..499, validation 500..999). For
each it writes ``figures/diagnostics_<name>_{residuals,gain,step}.png`` (residual
correlations on the validation record, gain with its 95 % bands beside the spectral
estimate from the validation record, step responses with their 95 % bands) and prints
the residual verdicts and the figures' file names as Markdown.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import moli  # noqa: E402
from moli.app import figures, frequency_figures  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from daisy_data import load  # noqa: E402
from twin_rotor import identify_rig  # noqa: E402
from moli.systems import TwinRotor  # noqa: E402


def twin_rotor() -> tuple[moli.StateSpaceModel, moli.IOData]:
    data, result = identify_rig(TwinRotor(), seed=0)
    return result.model, data


def evaporator() -> tuple[moli.StateSpaceModel, moli.IOData]:
    data = load("evaporator")
    result = moli.identify(data[0:500], data[500:1000], nmax=15)
    return result.model, data[500:1000]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs", help="folder holding figures/")
    args = parser.parse_args()
    folder = Path(args.out) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    for name, build in (("twin_rotor", twin_rotor), ("evaporator", evaporator)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model, validation = build()
        analysis = moli.residual_analysis(model, validation)
        drawn = {
            "residuals": analysis.plot(),
            "gain": frequency_figures.bode_magnitude(model, validation),
            "step": figures.step_responses(model, figures.settling_samples(model)),
        }
        print(f"### {name.replace('_', ' ')}: {model!r}\n")
        for line in analysis.verdicts:
            print(f"- {line}")
        print()
        for kind, fig in drawn.items():
            path = folder / f"diagnostics_{name}_{kind}.png"
            fig.savefig(path, dpi=100)
            print(f"![{name} {kind}](figures/{path.name})")
        print()


if __name__ == "__main__":
    main()
