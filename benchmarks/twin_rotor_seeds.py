"""Twin rotor identification over 10 seeds of excitation and noise.

Usage::

    python benchmarks/twin_rotor_seeds.py [--seeds 10]

For each seed: the paper's experiment on the simulated rig (60 s, binary inputs with
mean switching time 8 s, first 150 samples for estimation, whole record for the
order rule), the structure chosen, the VAF on the 450 samples never used for
estimation (simulation from rest), and the identified pitch mode against the rig's
linearisation. Run twice: the default rig (Coulomb friction, 2*pi/4096 encoder,
1e-3 rad white noise) and the same rig without Coulomb friction or quantisation,
where the linearisation is the small-signal truth.
"""

from __future__ import annotations


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402

import numpy as np  # noqa: E402

import moli  # noqa: E402
from moli.control import continuous_poles  # noqa: E402
from moli.systems import TwinRotor, TwinRotorParameters, identification_experiment  # noqa: E402

ESTIMATION = 150
OMEGA = moli.method.tuning.barycenter.grid(np.array([0.8, 1.04, 1.28, 1.52, 1.76, 2.0]) * np.pi, [0.5, 0.625, 0.75])
NMAX = 8


def pitch_pair(model: moli.StateSpaceModel, target: complex) -> complex | None:
    """The model's oscillatory pole nearest in modulus to ``target`` (None if it has none above 1 rad/s)."""
    s = continuous_poles(model.poles(), model.Ts)
    upper = s[s.imag > 1.0]
    return None if upper.size == 0 else complex(upper[np.argmin(np.abs(np.abs(upper) - abs(target)))])


RIGS = {
    "default": "default rig: Coulomb friction, encoder 2*pi/4096, noise sd 1e-3 rad",
    "no Coulomb": "no Coulomb friction, no quantisation, no noise (linearisation = small-signal truth)",
}


def make_rig(name: str) -> TwinRotor:
    """The two rigs of the study, by their key in ``RIGS``."""
    if name == "default":
        return TwinRotor(noise_std=1e-3)
    return TwinRotor(TwinRotorParameters(B2psi=0.0, B2phi=0.0), quantization=0.0)


def linear_pitch_pole(rig: TwinRotor) -> complex:
    """The pitch pole of the rig's linearisation at its trim."""
    lin = np.linalg.eigvals(rig.linearize()[0])
    return complex(lin[np.argmax(lin.imag)])


def identify_seed(rig: TwinRotor, seed: int) -> tuple[moli.IOData, moli.IdentificationResult]:
    """The paper's experiment on ``rig`` with ``seed``, identified on its first 15 s."""
    data = identification_experiment(rig, seed=seed)
    result = moli.identify(data[:ESTIMATION], validation=data, omega=OMEGA, nmax=NMAX,
                           seed=seed, center=False)
    return data, result


def seed_row(
    rig: TwinRotor, seed: int, identified: tuple[moli.IOData, moli.IdentificationResult] | None = None
) -> dict:
    """One seed: structure, unseen-sample VAF and identified pitch pole against the linearisation.

    ``identified`` is :func:`identify_seed`'s result when already at hand.
    """
    target = linear_pitch_pole(rig)
    zeta_lin = -target.real / abs(target)
    data, result = identify_seed(rig, seed) if identified is None else identified
    model = result.model
    vaf = moli.vaf(data.y[ESTIMATION:], model.simulate(data.u)[ESTIMATION:])
    pole = pitch_pair(model, target)
    row = {"seed": seed, "indices": [int(i) for i in model.indices],
           "vaf": [float(v) for v in vaf], "pole": None, "freq_error": None, "zeta_error": None}
    if pole is not None:
        row.update(pole=[pole.real, pole.imag], freq_error=100 * (abs(pole) / abs(target) - 1),
                   zeta_error=100 * ((-pole.real / abs(pole)) / zeta_lin - 1))
    return row


def study(rig: TwinRotor, seeds: range, label: str) -> list[dict]:
    """Rows of :func:`seed_row` for each seed, printed as they come."""
    target = linear_pitch_pole(rig)
    zeta_lin = -target.real / abs(target)
    print(f"\n== {label}")
    print(f"linearisation pitch pole {target:.4f}: |s| = {abs(target):.4f} rad/s, zeta = {zeta_lin:.4f}")
    print(f"{'seed':>4s} {'structure':>10s} {'VAF pitch':>9s} {'VAF yaw':>8s} {'mean':>6s} "
          f"{'pitch pole':>18s} {'d|s| %':>7s} {'dzeta %':>8s}")
    rows = []
    for seed in seeds:
        row = seed_row(rig, seed)
        rows.append(row)
        vaf = row["vaf"]
        pole_text = "none" if row["pole"] is None else f"{row['pole'][0]:.3f}{row['pole'][1]:+.3f}j"
        df = float("nan") if row["pole"] is None else row["freq_error"]
        dz = float("nan") if row["pole"] is None else row["zeta_error"]
        print(f"{seed:4d} {str(row['indices']):>10s} {vaf[0]:9.1f} {vaf[1]:8.1f} {np.mean(vaf):6.1f} "
              f"{pole_text:>18s} {df:7.1f} {dz:8.1f}")
    means = np.array([np.mean(r["vaf"]) for r in rows])
    print(f"mean validation VAF over {len(means)} seeds: {means.mean():.1f} % "
          f"(sd {means.std(ddof=1):.1f}, min {means.min():.1f}, max {means.max():.1f})")
    chosen = [tuple(r["indices"]) for r in rows]
    counts = {s: chosen.count(s) for s in sorted(set(chosen))}
    print("structures chosen:", ", ".join(f"{list(s)} x{c}" for s, c in counts.items()))
    fe = np.array([np.nan if r["pole"] is None else r["freq_error"] for r in rows])
    ze = np.array([np.nan if r["pole"] is None else r["zeta_error"] for r in rows])
    found = np.isfinite(fe)
    print(f"pitch pair found in {found.sum()}/{len(fe)} models; |s| error "
          f"{np.nanmin(fe):+.1f} .. {np.nanmax(fe):+.1f} %, damping error "
          f"{np.nanmin(ze):+.0f} .. {np.nanmax(ze):+.0f} %; within 10 % in frequency: "
          f"{np.sum(np.abs(fe[found]) <= 10)}, in damping: {np.sum(np.abs(ze[found]) <= 10)}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds (0, 1, ...)")
    args = parser.parse_args()
    for name, label in RIGS.items():
        study(make_rig(name), range(args.seeds), label)


if __name__ == "__main__":
    main()
