"""IdentifyOptions: every choice of an identification (docs/method.md §13), and the checks of
single option values."""

from .documentation import options_section
from .choices import PRESETS
from .identify_options import IdentifyOptions

__all__ = ["IdentifyOptions", "PRESETS", "options_section"]
