"""Every option with its default, as text for :func:`moli.identify`'s help.

Generated from :class:`IdentifyOptions` itself (its fields' defaults and the first sentence
of each field's description), so ``help(moli.identify)`` cannot drift from the options.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import MISSING, fields

from .identify_options import IdentifyOptions

__all__ = ["options_section"]


def _descriptions() -> dict[str, str]:
    """Each field's description in :class:`IdentifyOptions`' numpydoc Parameters, first sentence only."""
    text = (IdentifyOptions.__doc__ or "").split("Parameters\n    ----------\n", 1)[-1]
    found: dict[str, str] = {}
    for match in re.finditer(r"^    (\w+) : [^\n]*\n((?:        [^\n]*\n?)+)", text, flags=re.M):
        words = " ".join(match.group(2).split())
        found[match.group(1)] = re.split(r"(?<=\.)\s(?=[A-Z])", words, maxsplit=1)[0]
    return found


def options_section(indent: str = "    ") -> str:
    """A numpydoc "Other Parameters" section: every :class:`IdentifyOptions` field, its default
    and what it is.

    Examples
    --------
    >>> print(options_section().splitlines()[3])
        nmax : default None
    """
    described = _descriptions()
    lines = ["Other Parameters", "----------------",
             "Each field of IdentifyOptions, given as a keyword of ``**overrides``:"]
    for field in fields(IdentifyOptions):
        default = field.default if field.default is not MISSING else field.default_factory()  # type: ignore[misc]
        lines += [f"{field.name} : default {default!r}",
                  *textwrap.wrap(described.get(field.name, ""), 88, initial_indent="    ", subsequent_indent="    ")]
    return "\n".join(indent + line if line else line for line in lines) + "\n\n"
