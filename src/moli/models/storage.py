"""Model files: the JSON a :class:`StateSpaceModel` saves, read back and checked."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import DataError, ModelFileError
from .checks import matrix, stored_names
from .continuous import ContinuousModel
from .statespace import FILE_FORMAT, StateSpaceModel

__all__ = ["model_from_dict", "load_model"]


def model_from_dict(content: dict[str, Any]) -> StateSpaceModel | ContinuousModel:
    """Rebuild a model from :meth:`StateSpaceModel.to_dict` (or the continuous model's) output, checking it."""
    if not isinstance(content, dict):
        raise ModelFileError(f"not a moli model file: it holds a JSON {type(content).__name__}, "
                             "not an object with 'format': 'moli-model'")
    if content.get("format") != FILE_FORMAT:
        raise ModelFileError("not a moli model file (missing 'format': 'moli-model')")
    major = str(content.get("version", "")).split(".")[0]
    if major != __version__.split(".")[0]:
        raise ModelFileError(
            f"model file written by moli {content.get('version')}, which this moli "
            f"{__version__} cannot read"
        )
    try:
        if content.get("time") == "continuous":
            return ContinuousModel.from_dict(content)
        p, m = matrix("C", content["C"]).shape[0], matrix("B", content["B"]).shape[1]
        names = (stored_names("output_names", content["output_names"], p),
                 stored_names("input_names", content["input_names"], m))
        return StateSpaceModel(
            content["A"], content["B"], content["C"], content["D"], content["Ts"],
            output_names=names[0], input_names=names[1], indices=content.get("indices"),
            alpha=content.get("alpha"), y_offset=content.get("y_offset"), u_offset=content.get("u_offset"),
            info=content.get("info"), divisors=content.get("divisors"),
            K=content.get("K"), noise_cov=content.get("noise_cov"),  # absent in older files
            cov_factor=content.get("cov_factor"),
        ).with_input_delays(content.get("input_delays", 0))
    except KeyError as exc:
        raise ModelFileError(f"model file lacks the field {exc}") from None
    except DataError as exc:
        raise ModelFileError(f"model file is inconsistent: {exc}") from None
    except (TypeError, ValueError, OverflowError) as exc:  # a field no check foresaw: text, 10**400
        raise ModelFileError(f"model file is inconsistent: {exc}") from None


def load_model(path: str | Path) -> StateSpaceModel | ContinuousModel:
    """Read a model written by :meth:`StateSpaceModel.save` or :meth:`ContinuousModel.save`.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    StateSpaceModel or ContinuousModel
    """
    if not isinstance(path, (str, Path)):
        raise ModelFileError(f"path must be a str or Path, got {type(path).__name__}")
    try:
        content = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ModelFileError(f"no model file at {path}") from None
    except OSError as exc:  # a folder, no permission
        raise ModelFileError(f"cannot read the model file {path}: {exc.strerror}") from None
    except (ValueError, RecursionError) as exc:  # bad JSON, bad UTF-8, nesting or integers past Python's limits
        raise ModelFileError(f"{path} is not a JSON model file: {exc}") from None
    try:
        return model_from_dict(content)
    except ModelFileError as exc:
        raise ModelFileError(f"{path}: {exc}") from None
