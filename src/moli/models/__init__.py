"""The identified model: a discrete-time state-space model, its simulation, save and load;
its frequency response, input delays, continuous-time form and modes."""

from .continuous import ContinuousModel
from .modal import Mode, modes
from .statespace import StateSpaceModel
from .storage import load_model, model_from_dict

__all__ = ["StateSpaceModel", "ContinuousModel", "load_model", "model_from_dict", "Mode", "modes"]
