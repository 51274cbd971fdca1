"""``moli info``: a model described in words, sampled or continuous."""

from __future__ import annotations

import numpy as np

from ..data.display import console_text, number_text, period_text
from ..models.protocol import LinearModel

__all__ = ["describe"]


def describe(model: LinearModel) -> str:
    """A readable description of a model: structure, poles, stability, names, where it came from.

    A sampled model's poles are listed with their modulus; a continuous model's as time
    constants, or natural frequencies and damping, with its static gains.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel

    Returns
    -------
    str

    Examples
    --------
    >>> import moli
    >>> sampled = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], Ts=0.1)
    >>> print(describe(sampled).splitlines()[0])
    state-space model: n = 1, 1 outputs, 1 inputs, Ts = 0.1
    >>> print(describe(sampled.to_continuous()))
    continuous-time state-space model: n = 1, 1 outputs, 1 inputs
    outputs: y1
    inputs: u1
    inputs between samples: held (zoh)
    stable: yes (largest real part of a pole -6.931)
      s = -6.9315: time constant 0.1443
    static gain of y1: u1: 2
    """
    head = (f"continuous-time state-space model: n = {model.n}, {model.p} outputs, {model.m} inputs"
            if model.is_continuous else
            f"state-space model: n = {model.n}, {model.p} outputs, {model.m} inputs, "
            f"Ts = {period_text(model.Ts, model.info.get('time_unit'))}")
    lines = [head, f"outputs: {', '.join(map(console_text, model.output_names))}",
             f"inputs: {', '.join(map(console_text, model.input_names))}"]
    if model.is_continuous:
        if not str(model.info.get("method", "")).startswith("frequency"):   # a model of an FRF saw no samples
            held = {"zoh": "held", "foh": "linear"}[model.input_hold]
            lines.append(f"inputs between samples: {held} ({model.input_hold})")
        lines += _continuous_poles(model)
    else:
        lines += _sampled_structure(model)
    data = model.info.get("data")
    # a file edited or written elsewhere may hold anything there: described only as moli writes it
    if isinstance(data, dict) and isinstance(data.get("sha256"), str) and isinstance(data.get("N"), int):
        lines.append(f"estimated on {console_text(str(data.get('source', '?')))}: {data['N']} samples, "
                     f"sha256 {data['sha256'][:16]}...")
    return "\n".join(lines)


def _continuous_poles(model: LinearModel) -> list[str]:
    z = model.poles()
    lines = []
    if any(model.input_delays):
        lines.append(f"input delays ({model.info.get('time_unit') or 'time units'}): {list(model.input_delays)}")
    rightmost = f"largest real part of a pole {np.max(z.real):.4g}" if z.size else "no poles"
    lines.append(f"stable: {'yes' if model.is_stable() else 'NO'} ({rightmost})")
    # the poles as time constants, natural frequencies and damping; then the static gains
    return lines + model.pole_table()[1:]


def _sampled_structure(model: LinearModel) -> list[str]:
    z = model.poles()
    lines = []
    if any(model.input_delays):
        lines.append(f"input delays (samples): {list(model.input_delays)}")
    if model.indices is not None:
        lines.append(f"observability indices: {list(model.indices)}")
    if model.alpha is not None:
        lines.append(f"filter polynomial alpha: {np.array2string(model.alpha, precision=4)}")
    if model.divisors is not None:
        lines += [f"filter of output {j + 1}: {np.array2string(d, precision=4)}"
                  for j, d in enumerate(model.divisors)]
    if model.K is not None:
        std = ", ".join(f"{v:.4g}" for v in np.sqrt(np.diag(model.noise_cov)))
        lines.append(f"noise model: Kalman gain K ({model.n} x {model.p}), innovation std {std}")
    lines.append(f"stable: {'yes' if model.is_stable() else 'NO'} "
                 f"(largest pole modulus {number_text(np.max(np.abs(z), initial=0.0), 4)})")
    lines.append("poles (modulus):")
    lines += [f"  {number_text(p.real, 4, '+')} {number_text(p.imag, 4, '+')}j  ({number_text(abs(p), 4)})"
              for p in z[np.argsort(-np.abs(z))]]
    return lines
