"""A fleet's file records as its workers need them (absolute) and as its user named them.

Local workers may run in another folder than the caller, so a file item is handed to
them with an absolute path; what they say about it (a warning, an error naming the
file) is then turned back to the path the caller gave, so that a summary names the
files as the user typed them.
"""

from __future__ import annotations

import os
from typing import Any

from ..data.iodata import IOData

__all__ = ["absolute_paths", "as_given"]


def _parts(item: Any) -> list[Any]:
    return list(item) if isinstance(item, tuple) else [item]


def absolute_paths(item: Any) -> Any:
    """``item`` (a record, or an ``(estimation, validation)`` pair) with each file path made absolute."""
    if isinstance(item, tuple):
        return tuple(absolute_paths(part) for part in item)
    return item if isinstance(item, IOData) else os.path.abspath(item)


def as_given(message: str, item: Any, given: Any) -> str:
    """``message`` with every path of ``item`` written as the same part of ``given`` names it.

    Examples
    --------
    >>> import os
    >>> as_given(f"{os.path.abspath('plant/a.csv')}: Ts = 1", absolute_paths("plant/a.csv"), "plant/a.csv")
    'plant/a.csv: Ts = 1'
    """
    for path, path_as_given in zip(_parts(item), _parts(given)):
        if not isinstance(path, IOData) and str(path) != str(path_as_given):
            message = message.replace(str(path), str(path_as_given))
    return message
