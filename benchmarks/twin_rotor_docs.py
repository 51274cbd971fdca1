"""Regenerate every twin-rotor figure and number of docs/twin_rotor.md.

Usage::

    python benchmarks/twin_rotor_docs.py [--seeds 10]

Runs the study of ``examples/twin_rotor.py`` (identification of seed 0, LQ servo and
PID designs, the set-point and the saturation experiments) and writes its three
figures to ``docs/figures``; runs the seed study of ``twin_rotor_seeds.py`` on both
rigs; records every number in ``docs/twin_rotor_numbers.json`` and rewrites the
blocks of ``docs/twin_rotor.md`` that lie between ``<!-- generated: NAME -->`` and
``<!-- end generated: NAME -->`` from those numbers, leaving the prose around
them alone.

``tests/control/test_twin_rotor_docs.py`` checks that each block is exactly what
:func:`render` makes of the JSON file, and that the JSON file holds what the code
computes now (in full for the rig, the control design and both experiments; for
the seed study, seed 0 of the rig without Coulomb friction).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(HERE), str(ROOT / "examples")]

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402

import numpy as np  # noqa: E402

import twin_rotor as example  # noqa: E402
import twin_rotor_seeds as seeds  # noqa: E402
from moli import control as mc  # noqa: E402
from moli.systems import TwinRotor  # noqa: E402

DOC = ROOT / "docs" / "twin_rotor.md"
NUMBERS = ROOT / "docs" / "twin_rotor_numbers.json"
FIGURES = ROOT / "docs" / "figures"
BLOCK = re.compile(r"<!-- generated: (?P<name>[\w-]+) -->\n(?P<body>.*?)<!-- end generated: (?P=name) -->", re.S)


# -- numbers ------------------------------------------------------------------

def pair(z: complex) -> list[float]:
    """``[real, imag]`` of a complex number, for JSON."""
    return [float(z.real), float(z.imag)]


def rig_numbers(rig: TwinRotor) -> dict:
    """Trim, linearised pitch and yaw pairs, and the lowest pitch the main rotor can hold."""
    A, B, C = rig.linearize()
    poles = np.linalg.eigvals(A)
    upper = poles[poles.imag > 0]
    p = rig.params
    tau = -p.k1 * p.u_max / p.T10  # main rotor momentum at -u_max, steady state
    return {
        "profile_b": {k: getattr(p, k) for k in ("K_cab", "I2", "B1phi", "B2phi", "kc", "u_max")},
        "u_trim": rig.u_trim.tolist(),
        "pitch_pole": pair(upper[np.argmax(upper.imag)]),
        "yaw_pole": pair(upper[np.argmin(upper.imag)]),
        "lowest_pitch": math.asin((p.a1 * tau**2 + p.b1 * tau) / p.Mg),
        "static_gains": (C @ np.linalg.solve(-A, B)).tolist(),  # y = C (-A)^-1 B u at rest
    }


def step_rows(runs: dict[str, mc.ClosedLoopRun], windows: list, names: tuple[str, ...]) -> list[dict]:
    """Metrics of every step window of every run, with the seconds each input is saturated."""
    rows = []
    for controller, run in runs.items():
        for channel, start, stop in windows:
            m = mc.step_metrics(run, channel, start, stop)
            rows.append({
                "controller": controller, "step": example.step_label(run, channel, start, names),
                # JSON has no infinity: a set-point never reached settles at None.
                "iae": m.iae, "settling": m.settling_time if math.isfinite(m.settling_time) else None,
                "overshoot": m.overshoot,
                "steady_state_error": m.steady_state_error, "coupling": m.coupling,
                "saturated": mc.time_saturated(run, example.U_LIMITS, start, stop).tolist(),
            })
    return rows


def study_numbers(study: example.Study) -> dict:
    """Every number of the example's study that the doc shows."""
    names = study.rig.output_names
    pid = study.pid
    return {
        "settings": {"y_max": list(example.Y_MAX), "integral_max": list(example.INTEGRAL_MAX),
                     "u_max": list(example.U_MAX), "observer_bandwidth": example.OBSERVER_BANDWIDTH,
                     "saturation_steps": [list(s) for s in example.SATURATION_STEPS]},
        "identification": {"indices": [int(i) for i in study.model.indices],
                           "vaf_unseen": example.unseen_vaf(study.model, study.data).tolist()},
        "poles": {k: [pair(z) for z in v] for k, v in study.lq.pole_table().items()},
        "pid_gains": [[g.kp, g.ki, g.kd] for g in pid.gains],
        "steps": step_rows(study.runs, example.STEP_WINDOWS, names),
        "saturation": step_rows(study.saturation, example.SATURATION_WINDOWS, names),
        "peak_inputs": {k: np.max(np.abs(run.u), axis=0).tolist() for k, run in study.saturation.items()},
        "left_envelope": dict(study.left_envelope),
    }


def seed_numbers(count: int) -> dict:
    """The seed study on both rigs: the linearised pitch pole and one row per seed."""
    out = {}
    for name, label in seeds.RIGS.items():
        rig = seeds.make_rig(name)
        out[name] = {"pitch_pole": pair(seeds.linear_pitch_pole(rig)), "rows": seeds.study(rig, range(count), label)}
    return out


# -- rendering ----------------------------------------------------------------

def pole_text(z: list[float], digits: int = 3) -> str:
    """``"-0.122 ± 2.156j"`` for ``[real, imag]`` (one of a conjugate pair), or the real pole."""
    re_, im = z
    if abs(im) < 0.5 * 10**-digits:
        return f"{re_:.{digits}f}".replace("-", "−")
    return f"{re_:.{digits}f} ± {abs(im):.{digits}f}j".replace("-", "−")


def _poles(pairs: list[list[float]], digits: int = 3) -> str:
    """Conjugate pairs once, in the given order."""
    shown = [p for p in pairs if p[1] >= -0.5 * 10**-digits]
    return ", ".join(pole_text(p, digits) for p in shown)


def num_text(x: float | None, fmt: str) -> str:
    """``x`` formatted with a typographic minus; a dash for None or a non-finite number."""
    return ("—" if x is None or not math.isfinite(x) else format(x, fmt)).replace("-", "−")


def _step_table(rows: list[dict], saturation: bool) -> str:
    head = ["controller", "step", "IAE (rad·s)", "settling (s)", "overshoot (%)"]
    head += ["main / tail saturated (s)"] if saturation else ["steady-state error (rad)", "coupling (%)"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for r in rows:
        cells = [r["controller"], r["step"].replace("->", "→").replace("-", "−"), num_text(r["iae"], ".2f"),
                 num_text(r["settling"], ".1f"), num_text(r["overshoot"], ".1f")]
        if saturation:
            cells.append(f"{r['saturated'][0]:.1f} / {r['saturated'][1]:.1f}")
        else:
            cells += [num_text(r["steady_state_error"], ".0e"), num_text(r["coupling"], ".1f")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def render_rig(rig: dict) -> str:
    u, b, g = rig["u_trim"], rig["profile_b"], rig["static_gains"]
    return (
        f"- Profile B yaw axis: cable spring K_cab = {b['K_cab']:g} N·m/rad, inertia {b['I2']:g} kg·m², "
        f"viscous friction {b['B1phi']:g} N·m·s/rad, Coulomb friction {b['B2phi']:g}, reaction gain "
        f"kc = {num_text(b['kc'], 'g')}; rotor voltages saturated at ±{b['u_max']:g} V.\n"
        f"- Operating point: pitch 0.2 rad, yaw 0 (trim inputs {num_text(u[0], '.4f')} V, "
        f"{num_text(u[1], '.4f')} V). "
        f"The analytic linearisation (`linearize`, checked against central differences) has the pitch pair "
        f"{pole_text(rig['pitch_pole'], 4)} and the yaw pair {pole_text(rig['yaw_pole'], 3)}.\n"
        f"- Static gains of the linearisation (rad/V): main → pitch {num_text(g[0][0], '.2f')}, main → yaw "
        f"{num_text(g[1][0], '.2f')}, tail → pitch {num_text(g[0][1], '.2f')}, "
        f"tail → yaw {num_text(g[1][1], '.2f')}.\n"
        f"- Lowest pitch the main rotor can hold: {num_text(rig['lowest_pitch'], '.4f')} rad (−{b['u_max']:g} V, "
        f"reversed thrust against gravity); lower set-points are out of reach.\n"
    )


def seed_summary(rows: list[dict]) -> dict:
    """Aggregates of one rig's seed rows, as quoted in the doc."""
    means = np.array([np.mean(r["vaf"]) for r in rows])
    chosen = [tuple(r["indices"]) for r in rows]
    found = [r for r in rows if r["pole"] is not None]
    fe = np.array([r["freq_error"] for r in found])
    ze = np.array([r["zeta_error"] for r in found])
    sigma = np.array([-r["pole"][0] for r in found])
    worst = rows[int(np.argmin(means))]
    return {
        "mean": means.mean(), "sd": means.std(ddof=1), "min": means.min(), "max": means.max(),
        "structures": sorted(((list(s), chosen.count(s)) for s in set(chosen)), key=lambda t: (-t[1], t[0])),
        "found": len(found), "freq": (fe.min(), fe.max()), "zeta": (ze.min(), ze.max()),
        "zeta_within_10": int(np.sum(np.abs(ze) <= 10)), "sigma": (sigma.min(), sigma.max()),
        "worst": (worst["seed"], float(np.mean(worst["vaf"])), worst["vaf"]),
    }


def render_seeds(study: dict) -> str:
    label = {"default": "default (Coulomb, encoder 2π/4096, noise σ = 1e-3 rad)",
             "no Coulomb": "no Coulomb, no quantisation, no noise"}
    s = {name: seed_summary(study[name]["rows"]) for name in study}
    count = len(study["default"]["rows"])
    lines = [f"| rig | mean VAF ({count} seeds) | sd | min – max | structures chosen |",
             "| --- | --- | --- | --- | --- |"]
    for name, v in s.items():
        structures = ", ".join("{" + ",".join(map(str, st)) + "} ×" + str(c) for st, c in v["structures"])
        lines.append(f"| {label[name]} | {v['mean']:.1f} % | {v['sd']:.1f} | {v['min']:.1f} – {v['max']:.1f} "
                     f"| {structures} |")
    d, n = s["default"], s["no Coulomb"]
    zeta_lin = {k: -p[0] / math.hypot(*p) for k, p in ((k, study[k]["pitch_pole"]) for k in study)}
    seed, mean, vaf = d["worst"]
    lines += [
        "",
        f"- Pitch frequency against the linearisation: {num_text(d['freq'][0], '+.1f')} … "
        f"{num_text(d['freq'][1], '+.1f')} % on the default rig, {num_text(n['freq'][0], '+.1f')} … "
        f"{num_text(n['freq'][1], '+.1f')} % without Coulomb friction "
        f"(pitch pair found in {d['found']} and {n['found']} of {count} models).",
        f"- Pitch damping with Coulomb friction: {1 + d['zeta'][0] / 100:.1f}–{1 + d['zeta'][1] / 100:.1f} times the "
        f"linearisation's ζ = {zeta_lin['default']:.4f} (identified σ = {d['sigma'][0]:.2f}–{d['sigma'][1]:.2f}; "
        f"the paper's 0.11).",
        f"- Without Coulomb friction and quantisation the damping error is within 10 % on {n['zeta_within_10']} of "
        f"{count} seeds ({num_text(n['zeta'][0], '+.1f')} … {num_text(n['zeta'][1], '+.1f')} % on all {count}).",
        f"- Weakest seed on the default rig: {seed} (mean {mean:.1f} %, pitch {vaf[0]:.1f} %, yaw {vaf[1]:.1f} %).",
    ]
    return "\n".join(lines) + "\n"


def seed_line(row: dict) -> str:
    """One row of the per-seed table."""
    pole = "none" if row["pole"] is None else pole_text(row["pole"], 3)
    errors = (["—", "—"] if row["pole"] is None
              else [num_text(row["freq_error"], "+.1f"), num_text(row["zeta_error"], "+.1f")])
    structure = "{" + ",".join(map(str, row["indices"])) + "}"
    return (f"| {row['seed']} | {structure} | {row['vaf'][0]:.1f} | {row['vaf'][1]:.1f} | {np.mean(row['vaf']):.1f} "
            f"| {pole} | {errors[0]} | {errors[1]} |")


def render_seed_rows(study: dict) -> str:
    out = []
    for name, rig in study.items():
        out += [f"{name} rig, linearised pitch pole {pole_text(rig['pitch_pole'], 4)}:", "",
                "| seed | structure | VAF pitch (%) | VAF yaw (%) | mean | pitch pole | Δ\\|s\\| (%) | Δζ (%) |",
                "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        out += [seed_line(row) for row in rig["rows"]] + [""]
    return "\n".join(out)


def render_design(n: dict) -> str:
    s, ident, poles = n["settings"], n["identification"], n["poles"]
    gains = "; ".join(f"({g[0]:.3f}, {g[1]:.3f}, {g[2]:.3f})" for g in n["pid_gains"])
    structure = "{" + ",".join(map(str, ident["indices"])) + "}"
    return (
        f"- Identified model (seed 0): {structure}, VAF on the samples estimation never saw "
        f"{ident['vaf_unseen'][0]:.1f} % (pitch) and {ident['vaf_unseen'][1]:.1f} % (yaw).\n"
        f"- Bryson weights: pitch/yaw {s['y_max'][0]:g}/{s['y_max'][1]:g} rad, integrated errors "
        f"{s['integral_max'][0]:g}/{s['integral_max'][1]:g} rad·s, inputs {s['u_max'][0]:g} V; observer poles at "
        f"{s['observer_bandwidth']:g} rad/s in a ±45° sector.\n"
        f"- Poles in continuous time (rad/s): model {_poles(poles['model'])}; closed loop "
        f"{_poles(poles['closed loop'])}; observer {_poles(poles['observer'], 2)}.\n"
        f"- PID gains (kp, ki, kd), pitch loop then yaw loop: {gains}.\n"
    )


def render_steps(n: dict) -> str:
    return _step_table(n["steps"], saturation=False) + "\n"


def render_saturation(n: dict) -> str:
    peaks = n["peak_inputs"]
    left = [k for k, v in n["left_envelope"].items() if v]
    tail = "; ".join(f"{k} {v[1]:.2f} V" for k, v in peaks.items())
    return (_step_table(n["saturation"], saturation=True) + "\n\n"
            f"- Largest tail-rotor input: {tail}.\n"
            f"- Left the rig's angle envelope: {'; '.join(left) if left else 'none'}.\n")


def render(numbers: dict) -> dict[str, str]:
    """Markdown of every generated block of the doc, by block name."""
    blocks = {"rig": render_rig(numbers["rig"])}
    if "study" in numbers:
        blocks.update(design=render_design(numbers["study"]), steps=render_steps(numbers["study"]),
                      saturation=render_saturation(numbers["study"]))
    if "seeds" in numbers:
        blocks.update(seeds=render_seeds(numbers["seeds"]), seed_rows=render_seed_rows(numbers["seeds"]))
    return blocks


def read_blocks(text: str) -> dict[str, str]:
    """The generated blocks of a doc, by name."""
    return {m["name"]: m["body"] for m in BLOCK.finditer(text)}


def write_blocks(text: str, blocks: dict[str, str]) -> str:
    """``text`` with each named block replaced; every block must already have its markers."""
    missing = set(blocks) - set(read_blocks(text))
    if missing:
        raise SystemExit(f"{DOC} lacks the markers of blocks {sorted(missing)}")
    return BLOCK.sub(lambda m: f"<!-- generated: {m['name']} -->\n{blocks.get(m['name'], m['body'])}"
                     f"<!-- end generated: {m['name']} -->", text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds of the identification study")
    args = parser.parse_args()
    study = example.run_study(0)
    example.write_figures(study, FIGURES)
    numbers = {"rig": rig_numbers(study.rig), "study": study_numbers(study), "seeds": seed_numbers(args.seeds)}
    NUMBERS.write_text(json.dumps(numbers, indent=1) + "\n")
    DOC.write_text(write_blocks(DOC.read_text(), render(numbers)))
    print(f"wrote {NUMBERS.relative_to(ROOT)}, {DOC.relative_to(ROOT)} "
          f"and the figures in {FIGURES.relative_to(ROOT)}/")


if __name__ == "__main__":
    main()
