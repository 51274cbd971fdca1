"""The identified model: a discrete-time state-space model, its simulation, save and load."""

from .statespace import StateSpaceModel, load_model, model_from_dict

__all__ = ["StateSpaceModel", "load_model", "model_from_dict"]
