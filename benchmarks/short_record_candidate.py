"""A second model on short records, offered as a candidate: what the generalization benchmark says.

Reads ``generalization.json`` files of runs with the variants ``default`` and a candidate (e.g.
``kernel_arx``) and gives, per run: each against the best peer; the candidate against the default;
on the real records (DaISy halves and evaporator windows) the mean of the differences against the
best peer clipped to +-5 points and the records more than 2 points behind; on the synthetic
systems the median true-response fit and the gain bands' coverage. "chosen" is the rule under
test: the candidate replaces the default's model where its V1 VAF (the held-out part the orders
are chosen on) is higher; V2 scores it.

    PYTHONPATH=src:benchmarks python benchmarks/short_record_candidate.py /tmp/karx_0/generalization.json ...
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

CLIP, BEHIND = 5.0, 2.0


def _v(score: dict, key: str) -> float:
    return score.get(key, 0.0) if "error" not in score else 0.0


def _chosen(case: dict, candidate: str) -> dict:
    default, other = case["moli"]["default"], case["moli"][candidate]
    return other if _v(other, "v1") > _v(default, "v1") else default


def _versus(ours: np.ndarray, theirs: np.ndarray) -> str:
    d = ours - theirs
    return (f"{d.mean():+.2f} / {np.median(d):+.2f} ({int(np.sum(d > 1))} better, {int(np.sum(d < -1))} worse)"
            if len(d) else "—")


def summary(report: dict, candidate: str) -> list[str]:
    cases = report["cases"]
    peer = np.array([c["best_peer"]["v2"] if c["best_peer"] else 0.0 for c in cases])
    scores = {"default": [c["moli"]["default"] for c in cases], candidate: [c["moli"][candidate] for c in cases],
              "chosen": [_chosen(c, candidate) for c in cases]}
    v2 = {name: np.array([_v(s, "v2") for s in got]) for name, got in scores.items()}
    real = np.array([c["group"] != "synthetic" for c in cases])
    seed = report["command"].split("--seed ")[1].split()[0] if "--seed " in report["command"] else "0"
    out = [f"### Seed {seed}: {len(cases)} cases, {int(real.sum())} of them real records", "",
           "| model | against the best peer, mean / median (by a point) | against the default | real: mean clipped "
           "difference, records > 2 behind | real against the default | synthetic against the default | "
           "synthetic true fit, median | gain-band coverage | seconds per case |",
           "|---|---|---|---|---|---|---|---|---|"]
    for name, got in scores.items():
        d = np.clip(v2[name][real] - peer[real], -CLIP, CLIP)
        synth = [s for s, r in zip(got, real) if not r]
        coverage = np.array([s.get("coverage", np.nan) for s in synth], dtype=float)
        seconds = np.mean([s.get("seconds", np.nan) for s in got]) if name != "chosen" else \
            np.mean([a.get("seconds", 0) + b.get("seconds", 0) for a, b in zip(scores["default"], scores[candidate])])
        out.append(f"| {name} | {_versus(v2[name], peer)} | {_versus(v2[name], v2['default'])} | {d.mean():+.2f}, "
                   f"{int(np.sum(d < -BEHIND))} | {_versus(v2[name][real], v2['default'][real])} | "
                   f"{_versus(v2[name][~real], v2['default'][~real])} | "
                   f"{np.median([s.get('true_fit', 0.0) for s in synth]):.2f} | {np.nanmean(coverage):.3f} | "
                   f"{seconds:.2f} |")
    out += ["", f"Real records (V2 VAF): best peer, default, {candidate}, chosen (V1 of default / {candidate})", "",
            f"| case | N_E | peer | default | {candidate} | chosen | V1 default / {candidate} |",
            "|---|---|---|---|---|---|---|"]
    for c, p, is_real in zip(cases, peer, real):
        if is_real:
            d, k, ch = (_v(s, "v2") for s in (c["moli"]["default"], c["moli"][candidate], _chosen(c, candidate)))
            out.append(f"| {c['name']} | {c['N']} | {p:.2f} | {d:.2f} | {k:.2f} | {ch:.2f} | "
                       f"{_v(c['moli']['default'], 'v1'):.2f} / {_v(c['moli'][candidate], 'v1'):.2f} |")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("reports", nargs="+", help="generalization.json files")
    parser.add_argument("--candidate", default="kernel_arx", help="the variant offered beside the default")
    args = parser.parse_args()
    for path in args.reports:
        print("\n".join(summary(json.loads(Path(path).read_text()), args.candidate)), "\n", sep="")


if __name__ == "__main__":
    main()
