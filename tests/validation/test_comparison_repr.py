"""What ``print(moli.compare(...))`` shows: the scores per output, not the simulated array."""

from __future__ import annotations

import numpy as np

import moli


def test_printed_comparison_is_a_table_of_scores_per_output():
    data = moli.example_data(N=300, seed=1)
    model = moli.identify(data, nmax=4, refine="none").model
    scores = moli.compare(model, data)
    shown = str(scores)
    assert shown == repr(scores)
    lines = shown.splitlines()
    assert lines[0] == "simulation on 300 samples: VAF and NRMSE fit, percent"
    for line, name, v, f in zip(lines[2:], data.output_names, scores.vaf, scores.fit):
        assert line.split() == [name, f"{v:.2f}", f"{f:.2f}"]
    assert lines[-1].split() == ["mean", f"{scores.mean_vaf:.2f}", f"{np.mean(scores.fit):.2f}"]
    assert "array" not in shown and len(lines) == data.p + 3
    assert str(moli.compare(model, data, horizon=1)).startswith("1-step prediction on 300 samples")
