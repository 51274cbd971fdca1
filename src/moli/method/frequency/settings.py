"""Which fields of IdentifyOptions a frequency-domain identification reads, and the ones it refuses.

Read: ``nmax`` and ``order`` (the orders tried), ``order_rule`` (only the paired rule,
the default for these data), ``order_errors`` (its standard errors), ``feedthrough``
(``D`` estimated unless False), ``max_radius`` (None allows unstable models; a number
bounds a discrete model's poles, and any number keeps a continuous model's poles in the
left half-plane) and ``refine`` ("none": the subspace start; "selected": the start orders
the models, the selected one is refined; "path": every order refined; "guarded": every
order refined, the refinement kept where the held-out lines prefer it), ``frequency_start``
("both": the MOLI start beside the subspace one at each order) and ``delays`` (0: none; "auto":
a pure delay per input, fitted and kept where the held-out lines prefer it; sampled data also
take whole samples per input, :mod:`.delays`). ``seed`` and
``center`` have nothing to act on and are accepted as they are. Every other field is a
choice of the time-domain method (filters, structure lists, records): one changed from
its default is refused, so that no choice is silently ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ...errors import OptionError
from ..options import IdentifyOptions

__all__ = ["FrequencySettings", "frequency_settings", "refuse_frequency_options", "READ", "ACCEPTED"]

READ = ("nmax", "order", "order_rule", "order_errors", "feedthrough", "max_radius", "refine", "frequency_start",
        "delays")
ACCEPTED = ("seed", "center", "time")


@dataclass(frozen=True)
class FrequencySettings:
    """The choices of one frequency-domain identification."""

    nmax: int
    order: int | None
    z: float
    feedthrough: bool
    radius: float | None
    refine: str
    moli_start: bool
    delays: int | tuple[int, ...] | str = 0


def frequency_settings(options: IdentifyOptions, continuous: bool, p: int) -> FrequencySettings:
    """The settings ``options`` give for data of ``p`` outputs from a continuous (or discrete) system."""
    default = IdentifyOptions()
    changed = [f.name for f in fields(IdentifyOptions) if f.name not in READ + ACCEPTED
               and getattr(options, f.name) != getattr(default, f.name)]
    if changed:
        raise OptionError(f"{', '.join(changed)} {'does' if len(changed) == 1 else 'do'} not apply to frequency data "
                          "(choices of the time-domain method); leave them at their defaults")
    if options.order_rule not in (None, "paired"):
        raise OptionError(f"order_rule {options.order_rule!r} does not apply to frequency data: the order is chosen "
                          "by the paired rule on held-out lines (order_rule='paired' or None)")
    if options.time == "continuous" and not continuous:
        raise OptionError("time='continuous' asks for a continuous-time model, but the frequency data give Ts "
                          "(a sampled system's response): build FrequencyData with Ts=None for continuous time")
    if continuous and options.delays not in (0, "auto"):
        raise OptionError(f"delays={options.delays!r} counts samples, which a continuous-time response has none "
                          "of: give delays='auto' (a delay in time units fitted per input) or 0")
    if options.max_radius == "auto":
        raise OptionError("max_radius='auto' is set from a record's length and does not apply to frequency data; "
                          "give a number in (0, 1] or None")
    return FrequencySettings(nmax=options.path_end(p), order=options.order, z=float(options.order_errors),
                             feedthrough=options.feedthrough is not False, radius=options.max_radius,
                             refine=options.refine, moli_start=options.frequency_start == "both",
                             delays=options.delays)


def refuse_frequency_options(options: IdentifyOptions) -> None:
    """Raise :class:`OptionError` where ``options`` make a choice that only frequency data have (for a time record)."""
    if options.frequency_start != "subspace":
        raise OptionError(f"frequency_start={options.frequency_start!r} applies to frequency data "
                          "(a FrequencyData), not to a time record; leave it at 'subspace'")
