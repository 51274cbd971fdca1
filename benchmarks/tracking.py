"""Tracking an abrupt plant change with the forgetting factor.

A seeded 3x3 plant (indices (2, 2, 2)) runs for 20 000 samples, then its matrices
are replaced by another seeded plant's. Every 25 samples the current model is
simulated on a fixed validation input and compared (VAF, docs/method.md §5)
with the noise-free output of the plant then running. Recovery: samples after the
change until the mean VAF is back above TARGET and stays there.
Run: python benchmarks/tracking.py
"""


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import numpy as np

import moli
from moli.streaming.recursive import RecursiveMoli
from moli.models.simulation import simulate_batch
from streaming_plant import StreamingPlant

INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)
BEFORE, AFTER, STEP, TARGET = 20_000, 4_000, 25, 95.0
u_val = np.random.default_rng(99).standard_normal((500, 3))


def mean_vaf(model: moli.StateSpaceModel, plant: StreamingPlant) -> float:
    truth = simulate_batch(plant.A[None], plant.B[None], plant.C[None], u_val)[0]
    return float(np.mean(moli.vaf(truth, model.simulate(u_val))))


for forgetting in (1.0, 0.995, 0.99, 0.98):
    plant, new = StreamingPlant(seed=0, noise=0.1), StreamingPlant(seed=7)
    est = RecursiveMoli(INDICES, ALPHA, 3, forgetting=forgetting)
    est.update_many(*plant.chunk(BEFORE))
    before = mean_vaf(est.model, plant)
    plant.A, plant.B, plant.C = new.A, new.B, new.C  # abrupt change, state carried on
    history = []
    for _ in range(AFTER // STEP):
        est.update_many(*plant.chunk(STEP))
        history.append(mean_vaf(est.model, plant))
    history = np.array(history)
    below = np.flatnonzero(history < TARGET)
    recovered = "never" if below.size and below[-1] == len(history) - 1 else (
        f"{(below[-1] + 2 if below.size else 1) * STEP} samples")
    print(f"forgetting {forgetting}: VAF before change {before:.1f} %, after {AFTER} samples "
          f"{history[-1]:.1f} % (median of the last 1000: {np.median(history[-40:]):.1f} %), "
          f"back above {TARGET:.0f} % for good after {recovered}")
