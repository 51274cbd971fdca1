"""The identified model: a discrete-time state-space model, its simulation, save and load;
its frequency response, input delays and continuous-time form."""

from .continuous import ContinuousModel
from .statespace import StateSpaceModel
from .storage import load_model, model_from_dict

__all__ = ["StateSpaceModel", "ContinuousModel", "load_model", "model_from_dict"]
