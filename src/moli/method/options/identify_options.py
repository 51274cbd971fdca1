"""Every choice of an identification in one frozen, validated object.

:class:`IdentifyOptions` is what :func:`moli.identify` runs with, what a saved model
records and what ``moli fit --options FILE.json`` reads. The named presets are
instances of it (:meth:`IdentifyOptions.paper`, ...): nothing is set behind the
caller's back, and the repr shows every value.
"""

from __future__ import annotations

import difflib
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Mapping

from ...errors import OptionError
from .canonical import canonical_fields
from .choices import EVAPORATOR_CHOICES, FAST_CHOICES, PRESETS

__all__ = ["IdentifyOptions"]


@dataclass(frozen=True)
class IdentifyOptions:
    """Every choice of an identification (see docs/method.md for the method).

    Build one with keywords (every field is checked here, before any work), take a
    named preset (:meth:`default`, :meth:`fast`, :meth:`improved`, :meth:`bounded`,
    :meth:`paper`), or change a few fields of one with :meth:`replace`. The defaults were
    chosen on the generalization benchmark (docs/accuracy.md): the lowest order within 0.1
    point of the best validation fit, the wide filter grid, and output-error refinement kept
    where it raises the validation fit.

    Parameters
    ----------
    nmax : int, optional
        Largest McMillan degree on the greedy path; None: ``max(10, p + 4)``.
    order_rule : {"tolerance", "paired", "refined"}, optional
        How the order is picked on the validation record; None (the default) means
        "tolerance" in discrete time and "paired" in continuous time and for the
        two-stage closed-loop method (docs/continuous.md §5 and docs/closed_loop.md §4 give
        the measurements behind each): the lowest order within
        ``order_tolerance`` points of the best mean VAF; the lowest order whose
        validation error is within one paired standard error of the best model's
        (:func:`moli.method.selection.order_rules.select_order_paired`); or the same test with each
        order judged by the best refinement of the lists the greedy step compared there
        (:func:`moli.method.selection.order_rules.select_order_refined`, docs/method.md §5; the
        refinements judge the orders whatever ``refine`` does with the selected model).
    order : int, optional
        A fixed order: the path runs up to it (or to ``nmax``) and the model of this
        order is selected instead of applying the order rule; at least ``p``, at most
        ``nmax``. None: the order rule chooses.
    order_tolerance : float, default 0.1
        Points of mean validation VAF of the "tolerance" rule (0: the best order). The
        default 0.1 keeps orders that buy less than a tenth of a point out of the model
        (chosen on the generalization benchmark's seed 0, confirmed on seeds 1 and 2:
        docs/accuracy.md).
    order_errors : float, default 1.0
        Paired standard errors of tolerance of the "paired" and "refined" rules (0: the
        best order; larger: more parsimony).
    omega : sequence of (wc, zeta), optional
        Filter candidates, wc in rad per time unit of ``Ts``; None: the ``filter_grid``
        family scaled to ``Ts`` (:func:`moli.method.tuning.barycenter.default_omega`).
    filter_grid : {"wide", "paper", "damped", "wide3", "wider", "widez"}, default "wide"
        The family of filter candidates when ``omega`` is None
        (:func:`moli.method.tuning.barycenter.default_omega`).
    tuning : {"grid", "random", "zoom"}, default "grid"
        Filter search: one barycenter over ``omega``, the paper's randomized
        barycenter, or a grid refined around its best point.
    iterations : int, default 5
        Steps of the randomized or zoom filter search.
    s : float, default 2.0
        Root spacing factor of the filter polynomial (faster roots are powers ``z**s``).
    seed : int, default 0
        Seed of the randomized filter search.
    output_filters : bool, default True
        Re-tune each output's filter cutoff of every path model on J (docs/method.md §11).
    screen_lists : bool, default False
        The greedy step tunes only the candidate of lowest J at the raised list's filter (docs/method.md §5).
    path_patience : int, optional
        Stop the greedy path once this many orders in a row have not raised the best mean validation VAF of
        its stable models by more than ``order_tolerance`` (docs/method.md §5); None: up to ``nmax``.
    feedthrough : {True, False, "auto"}, default "auto"
        Direct feedthrough ``D``; "auto" keeps it per output where a nested F-test on
        the estimation data finds it significant (docs/method.md §8).
    max_radius : float, "auto" or None, default 1.0
        Filter candidates whose model has a pole of this modulus or more score the
        worst J; "auto": ``exp(-10/N)``; None (or "none"): no bound (docs/method.md §9).
    criterion_x0 : {"zero", "estimate"}, default "zero"
        Initial state of the estimation-data simulations behind J.
    trend_degree : int, default 2
        J ignores the polynomial trend of this degree in each output's simulation
        error, 0 to 5 (docs/method.md §10).
    refine : {"none", "selected", "path", "guarded"}, default "guarded"
        Output-error refinement of the selected model, or of every path model before the order rule
        (docs/method.md §12); "guarded": the selected model's refinement, kept only where it raises
        the mean validation VAF; another list the greedy step compared at that order, where its
        refinement is better by a paired standard error (``refine_siblings``); the order's generic
        list refined to its optimum, where its validation fit is within ``order_tolerance`` of the
        model so far; then the generic list of each order below, one order at a time, while it fits
        as well (``lower_orders``; not below a fixed ``order``). True and False mean "selected" and "none".
    refine_siblings : bool, default True
        With "guarded": refine the other lists the greedy step compared at the selected order and
        keep one where validation prefers it, as ``refine`` says (docs/method.md §12).
    lower_orders : bool, default True
        With "guarded": also try the generic list of each order below the selected one, refined to its
        optimum, while it fits validation within ``order_tolerance`` (docs/method.md §12, "The orders below").
    screen_generic : bool, default False
        With "guarded": judge the generic list at its early stop, and take only a kept one on to its
        optimum, kept where it still fits as well (docs/method.md §12, "The generic list").
    polish_selected : bool, default True
        With "guarded": continue the selected model's free refinement to its optimum and keep that where
        it fits validation better by two paired standard errors (docs/method.md §12, "The selected model's optimum").
    refine_iterations : int, default 10
        Most Levenberg-Marquardt steps of each refinement compared on validation (the
        generic list's then runs on to its optimum, docs/method.md §12).
    refine_ridge : float or tuple of float, default (0.0, 1.0)
        Penalty of the refinement toward the MOLI estimate, relative to each
        parameter's curvature (docs/method.md §12); 0: free refinement. Several values:
        "guarded" refines the MOLI estimate once with each and keeps the one that raises
        the mean validation VAF most (or none); "selected" and "path" use the first. The
        earlier presets use 1.
    center : bool, default True
        Remove the estimation record's means from both records (the model stores them).
    x0 : {"zero", "estimate"}, default "zero"
        Initial state of the validation simulations of the order rule.
    noise_model : bool, default True
        Attach a noise model (Kalman gain ``K`` and innovation covariance) to the
        selected model, estimated from its residuals on the estimation record
        (docs/noise_model.md); it leaves ``A, B, C, D`` and the path unchanged.
    regularization : {"none", "gcv"}, default "none"
        Plain least squares for every estimate, or ridge with the weight chosen per
        output by generalized cross-validation (docs/method.md §16; docs/accuracy.md
        shows it does not raise the fit on fresh data across the benchmark).
    delays : int, sequence of int or "auto", default 0
        Dead time of each input in samples (one int: every input): the model is
        estimated on the shifted inputs and carries them (``model.input_delays``).
        "auto": per input, the least over the outputs of :func:`moli.estimate_delays` on
        the estimation record (docs/diagnostics.md §3).
    search_samples : int or None, default 32768
        On a longer estimation record, the filter tuning, the greedy path, the
        refinement and the noise model run on its first ``search_samples`` samples, and
        the selected list is re-estimated on the whole record (docs/method.md §15);
        None searches the whole record however long. At least
        :data:`moli.method.options.choices.MIN_SEARCH_SAMPLES`.
    time : {"discrete", "continuous"}, default "discrete"
        A sampled model, or ``dx/dt = A x + B u`` identified directly from the record's
        time stamps, regular or not (docs/continuous.md): ``omega`` is then in rad per
        time unit of the stamps, the order rules "tolerance" and "paired" apply, and
        the feedthrough, refinement, noise model, per-output filters, delays and
        ``search_samples`` do not.
    input_hold : {"zoh", "foh"}, default "zoh"
        Continuous time: the input between samples, held or linear (the outputs are
        taken as linear between samples).
    reference : sequence of str, optional
        Names of input channels of the records that are logged references (set-points
        of the loops), not plant inputs: the model has the other inputs. They select the
        two-stage closed-loop method unless ``closed_loop`` says otherwise
        (docs/closed_loop.md).
    closed_loop : {"open", "two-stage", "direct"}, optional
        How a record taken under feedback is identified (docs/closed_loop.md): as if the
        loop were open; by the two-stage method (the part of each input that the
        ``reference`` explains replaces the input); or by the direct prediction-error
        method (the model and its Kalman gain jointly). None (the default): "two-stage"
        when a ``reference`` is named; else "direct" where the feedback check finds an
        input that the outputs reproduce exactly (a controller's output) and
        ``feedthrough`` is not True; else "open", which warns when the record looks
        closed-loop. "open" keeps the open-loop fit whatever the check finds.
    method : {"moli", "kernel", "kernel-arx"}, default "moli"
        What estimates the model: the MOLI path; the realization of a regularized impulse response
        (:func:`moli.identify_kernel`); or the balanced reduction of a regularized ARX model
        (:func:`moli.identify_kernel_arx`), each with its order chosen on validation
        (docs/regularization.md). The kernel methods read ``nmax``, ``x0``, ``center``, ``feedthrough`` and ``kernel``.
    kernel : {"TC", "DC", "SS", "none"}, default "TC"
        The prior of the kernel methods (on each impulse response, or each ARX polynomial); any
        other than "TC" with the MOLI path is an error.
    frequency_start : {"subspace", "both"}, default "subspace"
        Frequency data only: each order's model grows from the frequency-domain subspace
        start, or from it and the MOLI start on the frequency grid, the better refined
        model on the held-out lines kept (docs/frequency.md §2b: "both" changed no figure
        and doubled the time).

    Examples
    --------
    >>> opts = IdentifyOptions(nmax=8)
    >>> opts.nmax, opts.feedthrough
    (8, 'auto')
    >>> IdentifyOptions.paper().tuning
    'random'
    >>> IdentifyOptions.from_dict(opts.to_dict()) == opts
    True
    """

    nmax: int | None = None
    order_rule: str | None = None
    order: int | None = None
    order_tolerance: float = 0.1
    order_errors: float = 1.0
    omega: tuple[tuple[float, float], ...] | None = None
    filter_grid: str = "wide"
    tuning: str = "grid"
    iterations: int = 5
    s: float = 2.0
    seed: int = 0
    output_filters: bool = True
    screen_lists: bool = False
    path_patience: int | None = None
    feedthrough: bool | str = "auto"
    max_radius: float | str | None = 1.0
    criterion_x0: str = "zero"
    trend_degree: int = 2
    refine: str = "guarded"
    refine_siblings: bool = True
    lower_orders: bool = True
    screen_generic: bool = False
    polish_selected: bool = True
    refine_iterations: int = 10
    refine_ridge: float | tuple[float, ...] = (0.0, 1.0)
    center: bool = True
    x0: str = "zero"
    noise_model: bool = True
    regularization: str = "none"
    delays: int | tuple[int, ...] | str = 0
    search_samples: int | None = 2**15
    time: str = "discrete"
    input_hold: str = "zoh"
    reference: tuple[str, ...] | None = None
    closed_loop: str | None = None
    method: str = "moli"
    frequency_start: str = "subspace"
    kernel: str = "TC"

    def __post_init__(self) -> None:
        for name, value in canonical_fields(self).items():
            object.__setattr__(self, name, value)

    def path_end(self, p: int) -> int:
        """The order the greedy path runs to for ``p`` outputs: ``nmax``, else ``order``, else ``max(10, p + 4)``."""
        return self.nmax if self.nmax is not None else self.order if self.order is not None else max(10, p + 4)

    @classmethod
    def default(cls, **changes: Any) -> "IdentifyOptions":
        """The defaults (docs/accuracy.md): the lowest order within 0.1 point of the best
        validation fit, the wide filter grid, guarded refinement (free and with a ridge,
        the better on validation), and the improved preset's other choices."""
        return cls(**changes)

    @classmethod
    def fast(cls, **changes: Any) -> "IdentifyOptions":
        """The default search made cheaper at a small, measured cost in fit.

        :data:`~moli.method.options.choices.FAST_CHOICES`: screened greedy steps, a path stopped three orders after
        its best validation fit, no sibling lists, the generic list polished only where kept, five Levenberg-Marquardt
        steps per refinement, no orders below and no optimum of the selected model (bands kept): 1.8-2.4 points above
        the best subspace peer, 0.6-1.5 times SIPPY's N4SID sweep's CPU (docs/accuracy.md, "The fast preset").

        Returns
        -------
        IdentifyOptions
            The default options with :data:`~moli.method.options.choices.FAST_CHOICES`, then ``changes``
            (fields of :class:`IdentifyOptions` that replace the preset's values).

        Examples
        --------
        >>> IdentifyOptions.fast().refine_iterations
        5
        >>> IdentifyOptions.fast(nmax=8).refine
        'guarded'
        """
        return cls(**{**FAST_CHOICES, **changes})

    @classmethod
    def improved(cls, **changes: Any) -> "IdentifyOptions":
        """The earlier default, chosen on the evaporator windows: the paper's 18-point
        grid, lowest order within 1 point of the best, no refinement; "auto"
        feedthrough, unstable candidates scored worst, J blind to a quadratic drift,
        per-output filters."""
        return cls(**{**EVAPORATOR_CHOICES, **changes})

    @classmethod
    def bounded(cls, **changes: Any) -> "IdentifyOptions":
        """The improved preset with candidates whose modes are slower than a tenth of the
        record ruled out, ``s = 3``, the paper's J, one filter shared by the outputs."""
        return cls(**{**EVAPORATOR_CHOICES, "s": 3.0, "max_radius": "auto", "trend_degree": 0,
                      "output_filters": False, **changes})

    @classmethod
    def paper(cls, **changes: Any) -> "IdentifyOptions":
        """The paper's MOLI-ZOFT: its grid, randomized barycenter, ``s = 2``, no
        feedthrough, no stability bound, the paper's J, one shared filter, no
        refinement, lowest order within 1 point of the best."""
        return cls(**{**EVAPORATOR_CHOICES, "tuning": "random", "feedthrough": False,
                      "max_radius": None, "trend_degree": 0, "output_filters": False, **changes})

    @classmethod
    def preset(cls, name: str, **changes: Any) -> "IdentifyOptions":
        """The named preset (one of :data:`PRESETS`) with ``changes`` applied."""
        if name not in PRESETS:
            raise OptionError(f"preset must be one of {PRESETS}, got {name!r}")
        return getattr(cls, name)(**_known(changes))

    def replace(self, **changes: Any) -> "IdentifyOptions":
        """A copy with some fields changed (checked like the constructor)."""
        return replace(self, **_known(changes))

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON types: ``json.dumps(opts.to_dict())`` works."""
        out = asdict(self)
        if self.omega is not None:
            out["omega"] = [list(pair) for pair in self.omega]
        for name in ("delays", "reference"):
            if isinstance(out[name], tuple):
                out[name] = list(out[name])
        return out

    @classmethod
    def from_dict(cls, content: Mapping[str, Any]) -> "IdentifyOptions":
        """Options from :meth:`to_dict` output (or a JSON file's content).

        Missing fields take their defaults; an unknown one is an error that suggests
        the closest field.
        """
        if not isinstance(content, Mapping):
            raise OptionError(f"options must be a mapping of field names to values, got {type(content).__name__}")
        return cls(**_known(dict(content)))


FIELDS = tuple(f.name for f in fields(IdentifyOptions))


def _known(changes: Mapping[str, Any]) -> dict[str, Any]:
    """``changes`` unchanged, or an error naming the first unknown field and the closest one."""
    for name in changes:
        if name not in FIELDS:
            close = difflib.get_close_matches(str(name), FIELDS, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f"; the options are {', '.join(FIELDS)}"
            raise OptionError(f"unknown option {name!r}{hint}")
    return dict(changes)
