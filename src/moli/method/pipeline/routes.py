"""The identifications :func:`moli.identify` hands over whole: frequency data (docs/frequency.md),
before any split; continuous time (docs/continuous.md) and the kernel methods
(docs/regularization.md), once its records are split."""

from __future__ import annotations

from dataclasses import fields
from typing import Callable

from ...data.frequency_data import FrequencyData
from ...data.iodata import IOData
from ...errors import OptionError
from ..continuous.identification import ContinuousResult, identify_continuous
from ..frequency import FrequencyResult, identify_frequency, refuse_frequency_options
from ..kernel.arx_model import KernelArxResult, identify_kernel_arx
from ..kernel.kernel_model import KernelResult, identify_kernel
from ..options.choices import KERNEL_METHODS
from ..options.identify_options import IdentifyOptions

__all__ = ["frequency_route", "handed_over", "check_kernel_options", "HandedOver", "KERNEL_READS"]

# What the identifications handed over return.
HandedOver = FrequencyResult | ContinuousResult | KernelResult | KernelArxResult

# The options the kernel methods read; any other changed from its default is refused (it would
# be silently ignored).
KERNEL_READS = frozenset({"nmax", "x0", "center", "feedthrough", "method", "kernel"})


def check_kernel_options(options: IdentifyOptions) -> None:
    """Raise :class:`OptionError` where ``options`` ask for a kernel method with a choice it does not read.

    Parameters
    ----------
    options : IdentifyOptions
        Options whose ``method`` is "kernel" or "kernel-arx" (others pass).
    """
    if options.method not in KERNEL_METHODS:
        return
    if options.time == "continuous":
        raise OptionError(f"method={options.method!r} identifies sampled models: leave time at 'discrete'")
    default = IdentifyOptions()
    changed = [f.name for f in fields(IdentifyOptions)
               if f.name not in KERNEL_READS and getattr(options, f.name) != getattr(default, f.name)]
    if changed:
        raise OptionError(f"method={options.method!r} does not read {', '.join(changed)}: leave "
                          f"{'it' if len(changed) == 1 else 'them'} at the default, or use method='moli'")


def frequency_route(data: IOData | FrequencyData, validation: IOData | None, options: IdentifyOptions,
                    progress: Callable[..., None] | None, phase: Callable[[str], None] | None,
                    ) -> FrequencyResult | None:
    """The identification from frequency data where ``data`` is a :class:`FrequencyData`; None for a
    time record, once the options only frequency data take are refused for it."""
    if isinstance(data, FrequencyData):
        return identify_frequency(data, validation, options, progress, phase)
    refuse_frequency_options(options)
    return None


def handed_over(estimation: IOData, validation: IOData, source: str, options: IdentifyOptions,
                progress: Callable[..., None] | None, phase: Callable[[str], None] | None,
                ) -> HandedOver | None:
    """The result of the identification ``options`` ask for where it is not the sampled MOLI
    path's; None where it is."""
    check_kernel_options(options)
    if options.time == "continuous":
        return identify_continuous(estimation, validation, source, options, progress, phase)
    if options.method not in KERNEL_METHODS:
        return None
    if options.method == "kernel":
        result = identify_kernel(estimation, validation, kernel=options.kernel, nmax=options.nmax, x0=options.x0,
                                 center=options.center, feedthrough=options.feedthrough is True)
    else:
        result = identify_kernel_arx(estimation, validation, kernel=options.kernel, nmax=options.nmax,
                                     x0=options.x0, center=options.center, feedthrough=options.feedthrough)
    result.validation_source = source
    result.model.info["options"] = options.to_dict()      # as every identification records what made it
    return result
