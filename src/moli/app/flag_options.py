"""Command-line flags into :class:`IdentifyOptions`: the one place every command makes its options."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..errors import OptionError
from ..method.options import IdentifyOptions
from ..method.options.choices import KERNEL_METHODS

__all__ = ["options_from_flags"]


def options_from_flags(options_file: Path | None, preset: str | None, *, runs_kernel: bool = False,
                       **flags: Any) -> IdentifyOptions:
    """The one place where command-line flags become :class:`IdentifyOptions`.

    ``--options FILE`` (a JSON options dict, e.g. ``model.json``'s ``info.options``)
    or ``--preset`` gives the base; every flag given on the command line (not None)
    then replaces its field. A saved model's options keep the model's time domain: a
    continuous model's run in continuous time (``time`` is set from the file's own
    ``time``), and a file whose options say the other domain is refused. A file asking for a
    kernel method is refused unless the command runs it (``runs_kernel``).
    """
    given = {name: value for name, value in flags.items() if value is not None}
    if options_file is None:
        return IdentifyOptions.preset(preset or "default", **given)
    if preset is not None:
        raise OptionError("give either --options FILE or --preset, not both")
    try:
        content = json.loads(Path(options_file).read_text())
    except FileNotFoundError:
        raise OptionError(f"--options: no file at {options_file}") from None
    except OSError as exc:                       # a folder, no permission
        raise OptionError(f"--options: cannot read {options_file}: {exc.strerror or exc}") from None
    except (ValueError, RecursionError) as exc:  # bad JSON or UTF-8, too deep, integers too long
        raise OptionError(f"--options: {options_file} is not a JSON file: {exc}") from None
    if isinstance(content, dict) and content.get("format") == "moli-model":
        content = _model_options(content, options_file)
    options = IdentifyOptions.from_dict(content).replace(**given)
    if options.method in KERNEL_METHODS and not runs_kernel:
        raise OptionError(f"--options: {options_file} asks for method={options.method!r}, which identifies time "
                          f"records (moli fit DATA --method {options.method}, moli fit-many ... --method "
                          f"{options.method}), not this command's data: use method 'moli'")
    return options


def _model_options(model: dict[str, Any], options_file: Path) -> dict[str, Any]:
    """A saved model's options (the ones that made it), in the model's own time domain."""
    info = model.get("info")
    options = info.get("options", {}) if isinstance(info, dict) else {}
    if not isinstance(options, dict):
        raise OptionError(f"--options: {options_file} holds a model whose info.options is not a JSON object")
    domain = "continuous" if model.get("time") == "continuous" else "discrete"
    if options.get("time", domain) != domain:
        raise OptionError(f"--options: {options_file} holds a {domain}-time model whose options say "
                          f"time={options['time']!r}; the file is inconsistent: name the options in a file of their own")
    return {**options, "time": domain}
