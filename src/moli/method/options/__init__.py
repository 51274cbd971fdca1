"""IdentifyOptions: every choice of an identification (docs/method.md §13), and the checks of
single option values."""

from .identify_options import PRESETS, IdentifyOptions

__all__ = ["IdentifyOptions", "PRESETS"]
