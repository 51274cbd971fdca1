"""Conversion of a model to python-control (an optional dependency)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import OptionError

if TYPE_CHECKING:
    from .statespace import StateSpaceModel

__all__ = ["to_control"]


def to_control(model: "StateSpaceModel", noise: bool = False, continuous: bool = False) -> Any:
    """:meth:`StateSpaceModel.to_control`: a python-control ``StateSpace`` with the channel names."""
    if not isinstance(noise, bool) or not isinstance(continuous, bool):
        raise OptionError(f"noise and continuous must be True or False, got {noise!r} and {continuous!r}")
    if noise and model.K is None:
        raise OptionError("to_control(noise=True) needs a noise model, and model.K is None")
    if noise and continuous:
        raise OptionError("to_control gives the noise channels in discrete time only: "
                          "pass noise=True or continuous=True, not both")
    if continuous:
        return model.to_continuous().to_control()
    try:
        import control
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("to_control() needs python-control: pip install control") from exc
    plain = model.delays_as_states()
    if noise:
        # innovations do not enter the delay lines: K's rows for those states are zero
        K = np.zeros((plain.n, model.p))
        K[: model.n] = model.K
        return control.ss(
            plain.A, np.hstack([plain.B, K]), plain.C, np.hstack([plain.D, np.eye(model.p)]), model.Ts,
            inputs=[*model.input_names, *(f"e@{name}" for name in model.output_names)],
            outputs=list(model.output_names),
        )
    return control.ss(plain.A, plain.B, plain.C, plain.D, plain.Ts,
                      inputs=list(plain.input_names), outputs=list(plain.output_names))
