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
OMEGA = moli.method.tuning.grid(np.array([0.8, 1.04, 1.28, 1.52, 1.76, 2.0]) * np.pi, [0.5, 0.625, 0.75])
NMAX = 8


def pitch_pair(model: moli.StateSpaceModel, target: complex) -> complex | None:
    """The model's oscillatory pole nearest in modulus to ``target`` (None if it has none above 1 rad/s)."""
    s = continuous_poles(model.poles(), model.Ts)
    upper = s[s.imag > 1.0]
    return None if upper.size == 0 else complex(upper[np.argmin(np.abs(np.abs(upper) - abs(target)))])


def study(rig: TwinRotor, seeds: range, label: str) -> None:
    lin = np.linalg.eigvals(rig.linearize()[0])
    target = complex(lin[np.argmax(lin.imag)])
    zeta_lin = -target.real / abs(target)
    print(f"\n== {label}")
    print(f"linearisation pitch pole {target:.4f}: |s| = {abs(target):.4f} rad/s, zeta = {zeta_lin:.4f}")
    print(f"{'seed':>4s} {'structure':>10s} {'VAF pitch':>9s} {'VAF yaw':>8s} {'mean':>6s} "
          f"{'pitch pole':>18s} {'d|s| %':>7s} {'dzeta %':>8s}")
    means, freq_err, zeta_err, chosen = [], [], [], []
    for seed in seeds:
        data = identification_experiment(rig, seed=seed)
        result = moli.identify(data[:ESTIMATION], validation=data, omega=OMEGA, nmax=NMAX,
                               seed=seed, center=False)
        model = result.model
        vaf = moli.vaf(data.y[ESTIMATION:], model.simulate(data.u)[ESTIMATION:])
        means.append(vaf.mean())
        chosen.append(tuple(model.indices))
        pole = pitch_pair(model, target)
        if pole is None:
            pole_text, df, dz = "none", float("nan"), float("nan")
        else:
            df = 100 * (abs(pole) / abs(target) - 1)
            dz = 100 * ((-pole.real / abs(pole)) / zeta_lin - 1)
            pole_text = f"{pole.real:.3f}{pole.imag:+.3f}j"
        freq_err.append(df)
        zeta_err.append(dz)
        print(f"{seed:4d} {str(list(model.indices)):>10s} {vaf[0]:9.1f} {vaf[1]:8.1f} {vaf.mean():6.1f} "
              f"{pole_text:>18s} {df:7.1f} {dz:8.1f}")
    means = np.array(means)
    print(f"mean validation VAF over {len(means)} seeds: {means.mean():.1f} % "
          f"(sd {means.std(ddof=1):.1f}, min {means.min():.1f}, max {means.max():.1f})")
    counts = {s: chosen.count(s) for s in sorted(set(chosen))}
    print("structures chosen:", ", ".join(f"{list(s)} x{c}" for s, c in counts.items()))
    fe, ze = np.array(freq_err), np.array(zeta_err)
    found = np.isfinite(fe)
    print(f"pitch pair found in {found.sum()}/{len(fe)} models; |s| error "
          f"{np.nanmin(fe):+.1f} .. {np.nanmax(fe):+.1f} %, damping error "
          f"{np.nanmin(ze):+.0f} .. {np.nanmax(ze):+.0f} %; within 10 % in frequency: "
          f"{np.sum(np.abs(fe[found]) <= 10)}, in damping: {np.sum(np.abs(ze[found]) <= 10)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds (0, 1, ...)")
    args = parser.parse_args()
    seeds = range(args.seeds)
    study(TwinRotor(noise_std=1e-3), seeds,
          "default rig: Coulomb friction, encoder 2*pi/4096, noise sd 1e-3 rad")
    study(TwinRotor(TwinRotorParameters(B2psi=0.0, B2phi=0.0), quantization=0.0), seeds,
          "no Coulomb friction, no quantisation, no noise (linearisation = small-signal truth)")


if __name__ == "__main__":
    main()
