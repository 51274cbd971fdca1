"""Exceptions and warnings raised by moli.

Every exception subclasses :class:`ValueError`, so callers may catch either the
specific class or the builtin one. An argument of the wrong type (text where a number
goes, a number where a list of names goes) raises the subclass given by
:func:`wrong_type`, which is also a :class:`TypeError`.
"""

from __future__ import annotations

from typing import Any, Sequence

__all__ = [
    "MoliError", "DataError", "StructureError", "FilterError", "OptionError", "ModelFileError",
    "ControlDesignError", "wrong_type",
    "UnstableModelWarning", "IllConditionedWarning", "DataQualityWarning", "OrderBoundWarning",
    "ClosedLoopWarning", "IrregularSamplingWarning", "SamplingPeriodWarning", "ShortValidationWarning",
    "WeakReferenceWarning", "NoFitWarning", "FrequencyConventionWarning",
]


class MoliError(ValueError):
    """Base class of the errors moli raises on bad input."""


class DataError(MoliError):
    """The input-output data are unusable as given (shape, NaN, too short...)."""


class StructureError(MoliError):
    """A list of observability indices is invalid for the data."""


class FilterError(MoliError):
    """A filter polynomial is not monic, not stable, or cannot serve the list."""


class OptionError(MoliError):
    """An option has an unknown name or an invalid value."""


class ModelFileError(MoliError):
    """A saved model file is unreadable or inconsistent."""


class ControlDesignError(MoliError):
    """A controller cannot be designed or built with the given model or settings."""


def _type_variant(error: type[MoliError]) -> type[MoliError]:
    variant = type(f"_{error.__name__}OfType", (error, TypeError), {
        "__module__": __name__,
        "__doc__": f"{error.__name__} for an argument of the wrong type (also a TypeError).",
    })
    globals()[variant.__name__] = variant   # found by name, so it pickles across processes
    return variant


_TYPE_VARIANTS = {e: _type_variant(e) for e in (
    MoliError, DataError, StructureError, FilterError, OptionError, ModelFileError, ControlDesignError)}


def wrong_type(error: type[MoliError]) -> type[MoliError]:
    """The subclass of ``error`` raised for an argument of the wrong type: also a TypeError.

    Examples
    --------
    >>> issubclass(wrong_type(DataError), (DataError, TypeError))
    True
    """
    return _TYPE_VARIANTS.get(error, error)


class UnstableModelWarning(UserWarning):
    """An identified model has poles on or outside the unit circle."""


class IllConditionedWarning(UserWarning):
    """A least-squares problem is rank deficient or badly conditioned."""



class DataQualityWarning(UserWarning):
    """A record has a flaw that can make its model unreliable (see moli.data.check_data)."""


class OrderBoundWarning(UserWarning):
    """The selected order is the largest the structure search was allowed to reach, it fits
    the validation data clearly better (two paired standard errors) than every lower order,
    and the search's next order, where the record allows one, fits clearly better than both
    the bound's least squares and the model returned (refined as that model was): a higher
    order may fit better still. The kernel methods also raise it where their orders stop below
    the ``nmax`` asked for (the realization has no more states to give)."""


class ShortValidationWarning(UserWarning):
    """The validation part that chose the order is too short to tell the orders apart."""


class NoFitWarning(UserWarning):
    """The returned model fits an output no better than that output's mean on the validation data."""


class ClosedLoopWarning(UserWarning):
    """The estimation data look closed-loop: an input depends on past outputs."""


class WeakReferenceWarning(UserWarning):
    """The logged references explain little of a plant input: the loop is driven by its noise."""


class SamplingPeriodWarning(UserWarning):
    """Says where a reader took the sampling period from, when the caller did not give it.

    A period column, or a time column found by a name that looks like time or as the
    first column (how it was found), or that no time was found and ``Ts = 1`` is
    assumed, with how to set it. Not given for a column named ``time``, ``t``,
    ``timestamp``, ``date`` or ``datetime``; giving ``Ts=`` or the time column silences it.
    """


class FrequencyConventionWarning(UserWarning):
    """Says how a reader of frequency responses read a file: the frequency column and its
    unit, and each channel pair's columns (real and imaginary parts, or magnitude and phase
    with their units)."""


class IrregularSamplingWarning(UserWarning):
    """A record's time stamps are not evenly spaced; ``gaps`` says where.

    Attributes
    ----------
    gaps : tuple
        One :class:`moli.data.SamplingGap` per irregular step (sample index, the times
        on either side, the step and the samples it is missing).
    """

    def __init__(self, message: str, gaps: Sequence[Any] = ()) -> None:
        super().__init__(message)
        self.gaps = tuple(gaps)
