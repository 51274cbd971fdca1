"""IdentifyOptions: every field checked when built, JSON and saved-model round trips."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import moli
from moli import IdentifyOptions, OptionError

# field -> (a value of a wrong type, a value of the right type that is out of range)
BAD = {
    "nmax": ("8", 0),
    "order_rule": (1, "lowest"),
    "order": ("3", 0),
    "order_tolerance": ("1", -0.5),
    "order_errors": ("1", -1.0),
    "omega": (3.0, [(0.1, -0.7)]),
    "tuning": (1, "grid-search"),
    "filter_grid": (2, "fine"),
    "iterations": (2.5, 0),
    "s": ("2", 1.0),
    "seed": (1.5, -1),
    "output_filters": (1, None),
    "screen_lists": (1, None),
    "path_patience": ("3", 0),
    "feedthrough": (1, "yes"),
    "max_radius": ([1.0], 1.5),
    "criterion_x0": (0, "zeros"),
    "trend_degree": (2.0, 6),
    "refine": (1, "all"),
    "refine_iterations": ("10", 0),
    "refine_ridge": ("1", ()),
    "center": ("yes", None),
    "refine_siblings": ("no", None),
    "lower_orders": ("no", None),
    "screen_generic": ("yes", None),
    "polish_selected": ("yes", None),
    "x0": (None, "random"),
    "noise_model": ("yes", None),
    "regularization": (1, "lasso"),
    "delays": (1.5, -1),
    "search_samples": (2.0**15, 499),
    "time": ("sampled", 1),
    "input_hold": ("linear", None),
    "reference": (3, []),
    "closed_loop": (True, "indirect"),
    "method": ("ridge", None, 1),
    "frequency_start": (1, "moli"),
    "kernel": (1, "Gaussian"),
}


def test_every_field_has_bad_values_tested():
    assert set(BAD) == {f.name for f in dataclasses.fields(IdentifyOptions)}


@pytest.mark.parametrize("field", sorted(BAD))
@pytest.mark.parametrize("which", [0, 1], ids=["wrong type", "wrong value"])
def test_a_bad_field_is_named_in_the_error(field, which):
    with pytest.raises(OptionError, match=rf"IdentifyOptions\.{field} must be"):
        IdentifyOptions(**{field: BAD[field][which]})


def test_a_kernel_prior_other_than_tc_is_for_the_kernel_method_only():
    assert IdentifyOptions(method="kernel", kernel="SS").kernel == "SS"
    with pytest.raises(OptionError, match=r"IdentifyOptions\.kernel must be 'TC' unless method is 'kernel'"):
        IdentifyOptions(kernel="DC")


def test_accepted_spellings_are_normalized():
    opts = IdentifyOptions(nmax=np.int64(7), max_radius="none", refine=True, s=3, omega=np.array([[0.1, 0.7]]))
    assert (opts.nmax, type(opts.nmax)) == (7, int)
    assert opts.max_radius is None and opts.refine == "selected" and opts.s == 3.0
    assert opts.omega == ((0.1, 0.7),)
    assert IdentifyOptions(refine=False).refine == "none"
    assert IdentifyOptions(refine_ridge=[0, np.float64(2.5)]).refine_ridge == (0.0, 2.5)
    with pytest.raises(OptionError, match="refine_ridge must be"):
        IdentifyOptions(refine_ridge=(0.0, -1.0))


def test_options_are_frozen_and_replace_checks_again():
    opts = IdentifyOptions()
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.nmax = 3  # type: ignore[misc]
    assert opts.replace(nmax=5).nmax == 5 and opts.nmax is None
    with pytest.raises(OptionError, match="trend_degree"):
        opts.replace(trend_degree=9)


def test_unknown_names_suggest_the_closest_field():
    with pytest.raises(OptionError, match="did you mean 'order_tolerance'"):
        IdentifyOptions.from_dict({"order_tolerence": 0.5})
    est, val = moli.example_data(N=300, seed=2).split(200)
    with pytest.raises(OptionError, match="did you mean 'feedthrough'"):
        moli.identify(est, val, feedthrogh=False)


def test_presets_show_what_they_set():
    # the paper's MOLI-ZOFT (docs/method.md §13): randomized barycenter, no feedthrough,
    # no stability bound, the plain J, one shared filter
    paper = IdentifyOptions.paper()
    assert (paper.tuning, paper.feedthrough, paper.max_radius, paper.trend_degree, paper.output_filters) == (
        "random", False, None, 0, False)
    assert "tuning='random'" in repr(paper) and "feedthrough=False" in repr(paper)
    assert IdentifyOptions.preset("default") == IdentifyOptions() == IdentifyOptions.default()
    # the earlier default differs from today's in exactly the four choices it was tuned on
    changed = {k for k, v in IdentifyOptions.improved().to_dict().items() if IdentifyOptions().to_dict()[k] != v}
    assert changed == {"order_tolerance", "filter_grid", "refine", "refine_ridge"}
    assert IdentifyOptions.preset("bounded", nmax=4) == IdentifyOptions.bounded().replace(nmax=4)
    with pytest.raises(OptionError, match="preset must be one of"):
        IdentifyOptions.preset("quick")


def test_the_fast_preset_is_the_default_with_screened_steps_a_shorter_path_and_refinement_and_no_polishes():
    fast = IdentifyOptions.preset("fast")
    assert fast == IdentifyOptions.fast() == IdentifyOptions(screen_lists=True, path_patience=3, refine_siblings=False,
                                                             screen_generic=True, refine_iterations=5,
                                                             lower_orders=False, polish_selected=False)
    # seven choices differ from the default; the refinement stays guarded and the result
    # keeps its noise model (and so its bands and predictions)
    changed = {k for k, v in fast.to_dict().items() if IdentifyOptions().to_dict()[k] != v}
    assert changed == {"screen_lists", "path_patience", "refine_siblings", "screen_generic", "refine_iterations",
                       "lower_orders", "polish_selected"}
    assert (fast.refine, fast.noise_model, fast.filter_grid) == ("guarded", True, "wide")
    # a change given beside the preset wins over the preset's own value
    assert IdentifyOptions.fast(refine_iterations=7, nmax=6).refine_iterations == 7


@pytest.mark.parametrize("opts", [
    IdentifyOptions(), IdentifyOptions.paper(nmax=9, seed=3), IdentifyOptions.bounded(),
    IdentifyOptions.fast(), IdentifyOptions.fast(nmax=7),
    IdentifyOptions(omega=[(0.1, 0.7), (0.2, 1.1)], refine="path", max_radius=0.99),
    IdentifyOptions(search_samples=None), IdentifyOptions(search_samples=4096),
])
def test_json_round_trip(opts):
    assert IdentifyOptions.from_dict(json.loads(json.dumps(opts.to_dict()))) == opts


def test_bad_options_are_refused_before_any_work():
    # data that identify would reject is never looked at: the options fail first
    with pytest.raises(OptionError, match="order_tolerance"):
        moli.identify(None, order_tolerance="1")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="options must be an IdentifyOptions"):
        moli.identify(None, options={"nmax": 3})  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="either options or preset"):
        moli.identify(None, options=IdentifyOptions(), preset="paper")  # type: ignore[arg-type]


def test_keywords_preset_and_options_object_run_the_same_search(tmp_path):
    est, val = moli.example_data(N=500, seed=4).split(330)
    by_keywords = moli.identify(est, val, nmax=5, preset="paper")
    opts = IdentifyOptions.paper(nmax=5)
    by_object = moli.identify(est, val, opts)
    assert by_keywords.options == by_object.options == opts
    np.testing.assert_array_equal(by_keywords.model.A, by_object.model.A)
    # the saved model records the options that made it
    by_object.model.save(tmp_path / "m.json")
    loaded = moli.load_model(tmp_path / "m.json")
    assert IdentifyOptions.from_dict(loaded.info["options"]) == opts
    assert opts == IdentifyOptions.paper(nmax=5)  # identify left the caller's options alone


def test_nmax_below_the_output_count_is_refused():
    est, val = moli.example_data(N=300, seed=2).split(200)
    with pytest.raises(OptionError, match="nmax must be at least the number of outputs, 3"):
        moli.identify(est, val, nmax=2)


def test_identify_help_lists_every_option_with_its_default():
    import pydoc
    from dataclasses import fields

    text = pydoc.render_doc(moli.identify, renderer=pydoc.plaintext)
    for field in fields(moli.IdentifyOptions):
        assert f"{field.name} : default {getattr(moli.IdentifyOptions(), field.name)!r}" in text, field.name
    # placed among the parameters, before what identify returns
    assert text.index("Other Parameters") < text.index("Returns")
