"""Bad arguments to the public API: a moli exception that names what to fix, never a raw
numpy/scipy error, never a silent reading of the wrong thing (docs/api.md, "Errors")."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import moli


@pytest.fixture(scope="module")
def records() -> tuple[moli.IOData, moli.IOData]:
    return moli.example_data(N=400, seed=3).split(280)


@pytest.fixture(scope="module")
def refined(records) -> moli.IdentificationResult:
    estimation, validation = records
    return moli.identify(estimation, validation, nmax=4)


@pytest.mark.parametrize("field, value", [
    ("nmax", np.array([4])), ("s", np.array([2.5])), ("max_radius", np.array([0.9, 0.8])),
    ("delays", np.array([[1]])), ("refine_ridge", [np.array([1.0, 2.0])]),
    # a complex value would lose its imaginary part, a numpy bool would count as 1
    ("order_tolerance", np.complex128(0.5 + 1j)), ("order_tolerance", np.True_),
    ("omega", [(np.complex128(0.5 + 2j), 1.0)]),
])
def test_an_option_given_as_an_array_complex_or_bool_is_refused_by_name(field, value):
    with pytest.raises(moli.OptionError, match=f"IdentifyOptions.{field}"):
        moli.IdentifyOptions(**{field: value})


def test_numpy_scalars_and_zero_dimensional_arrays_are_numbers_and_flags():
    options = moli.IdentifyOptions(nmax=np.int64(4), s=np.array(2.5), center=np.False_, delays=np.array([1, 2]))
    assert (options.nmax, options.s, options.center, options.delays) == (4, 2.5, False, (1, 2))


@pytest.mark.parametrize("call", [
    lambda e, v: moli.method.impulse_response(e, length=20, feedthrough="False"),   # was read as true
    lambda e, v: moli.identify_kernel(e, v, nmax=3, length=20, feedthrough="no"),
    lambda e, v: moli.identify_kernel(e, v, nmax=3, center="no"),
    lambda e, v: moli.identify_kernel_arx(e, v, nmax=3, center="no"),
])
def test_the_kernel_methods_refuse_flags_that_are_not_true_or_false(records, call):
    with pytest.raises(moli.OptionError, match="must be True or False"):
        call(*records)


def test_the_covariance_of_a_refined_model_needs_more_output_values_than_unknowns(records, refined):
    # one sample of three outputs cannot say anything of 27 parameters: it gave bands 1e-14 wide
    with pytest.raises(moli.DataError, match="needs more output values than its"):
        moli.estimate_covariance(refined.model, records[1][:5])
    with pytest.raises(moli.DataError, match="first_stage"):
        moli.estimate_covariance(refined.model, records[1], first_stage="x")


def test_records_whose_channels_are_the_same_names_in_another_order_are_refused(records, refined):
    estimation, validation = records
    swapped = moli.IOData(validation.y[:, ::-1], validation.u, output_names=["y3", "y2", "y1"])
    with pytest.raises(moli.DataError, match="the same channels in another order"):
        moli.compare(refined.model, swapped)
    with pytest.raises(moli.DataError, match="the same channels in another order"):
        moli.identify(estimation, swapped, nmax=4)
    with pytest.raises(moli.DataError, match="the same channels in another order"):
        moli.identify_kernel(estimation, swapped, nmax=3)
    # other names altogether say nothing of the order: matched by position as before
    renamed = moli.IOData(validation.y, validation.u, output_names=["a", "b", "c"])
    assert moli.compare(refined.model, renamed).vaf.shape == (3,)


@pytest.mark.parametrize("indices", [[2.9], "12", 2, []])
def test_filter_indices_must_be_a_list_of_positive_integers(indices):
    with pytest.raises(moli.FilterError):
        moli.filter_polynomial(0.5, 1.0, indices)


def test_a_filter_whose_roots_round_to_the_unit_circle_is_refused(records):
    with pytest.raises(moli.FilterError, match="too slow for Ts"):
        moli.filter_polynomial(1e-300, 1.0, [2])
    # before the search, naming omega, not from the refinement's check of the selected filter
    with pytest.raises(moli.OptionError, match="omega's candidate"):
        moli.identify(*records, nmax=4, omega=[(1e-9, 1.0)])


def test_every_default_grid_passes_the_filter_check():
    from moli.method.structure.filters import check_candidates
    from moli.method.tuning.barycenter import GRIDS, default_omega

    for family in GRIDS:
        check_candidates(default_omega(1.0, family), 1.0)


@pytest.mark.parametrize("index", [slice(None, None, 0), slice(1.5, 3), 3])
def test_a_record_is_sliced_by_integer_slices_with_a_step(index):
    with pytest.raises(moli.DataError):
        moli.example_data(N=100, seed=1)[index]


def test_dates_are_no_signal_and_masked_samples_are_missing():
    u = np.random.default_rng(0).standard_normal(50)
    with pytest.raises(moli.DataError, match="datetime64"):
        moli.IOData(np.arange(50).astype("datetime64[s]"), u)
    y = np.ma.masked_array(np.sin(np.arange(50.0)), mask=np.arange(50) == 20)
    y.data[20] = 1e9                      # the stored value under the mask is not a sample
    record = moli.IOData(y, u)
    assert record.N == 49 and record.n_segments == 2 and np.max(np.abs(record.y)) <= 1.0


def test_modes_and_continuous_simulation_refuse_what_is_not_theirs(refined):
    with pytest.raises(moli.DataError, match="pass its .model"):
        moli.modes(refined)
    continuous = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]]).to_continuous()
    with pytest.raises(moli.DataError, match="x0"):
        continuous.simulate_at(np.ones(5), np.arange(5.0), x0="zero")
    with pytest.raises(moli.DataError, match="u must be"):
        continuous.simulate_at("abc", np.arange(3.0))


def test_streaming_arguments_are_checked():
    alpha = moli.filter_polynomial(0.5, 1.0, [2, 1, 1])
    with pytest.raises(moli.DataError, match="states"):
        moli.ChunkedEstimator([2, 1, 1], alpha, 3).resume(150, "x")
    for kwargs in ({"m": None}, {"m": "a"}, {"m": 1, "window": "10"}):
        with pytest.raises(moli.OptionError):
            moli.FilterBank([1], [(0.5, 1.0)], **kwargs)


@pytest.mark.parametrize("kwargs", [
    {"seed": -1}, {"seed": 2.5}, {"levels": "ab"}, {"levels": (np.nan, 1.0)}, {"max_draws": 0},
    {"levels": (1.0, 1.0)},               # a constant "binary" signal
    {"N": True},
])
def test_random_binary_signal_refuses_bad_arguments(kwargs):
    arguments = {"N": 100, "mean_switch_time": 5.0, **kwargs}
    with pytest.raises(moli.MoliError):
        moli.random_binary_signal(**arguments)


def test_a_repeated_column_name_is_refused_not_read_as_its_first(tmp_path):
    frame = pd.DataFrame([[1.0, 2.0, 3.0]] * 5, columns=["u", "u", "y"])
    with pytest.raises(moli.DataError, match="two columns named 'u'"):
        moli.from_dataframe(frame, ["u"], ["y"])
    path = tmp_path / "repeated.csv"
    path.write_text("u,u,y\n" + "".join(f"{k},{2 * k},{3 * k}\n" for k in range(5)))
    with pytest.raises(moli.DataError, match="names the column .u. 2 times"):
        moli.read_data(path, inputs=["u"], outputs=["y"])


def test_saving_a_model_says_what_cannot_be_written(tmp_path):
    with pytest.raises(moli.DataError, match="JSON cannot store"):
        moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]], info={"a": np.arange(3)}).save(tmp_path / "m.json")
    model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    for target in (tmp_path, tmp_path / "missing" / "m.json"):
        with pytest.raises(moli.ModelFileError, match="cannot write the model"):
            model.save(target)
    assert list(tmp_path.iterdir()) == []          # nothing half written


def test_indices_must_match_the_model():
    with pytest.raises(moli.DataError, match="summing to the order"):
        moli.StateSpaceModel(np.eye(2) * 0.5, np.ones((2, 1)), np.ones((1, 2)), indices=[5])


def test_kernel_orders_that_stop_below_the_nmax_asked_for_say_so(records):
    # the 40-lag impulse response's Hankel matrix gives at most 60 states: nmax=1000 was cut silently
    with pytest.warns(moli.OrderBoundWarning, match="below nmax = 1000"):
        moli.identify_kernel(*records, nmax=1000)
    with pytest.warns(moli.OrderBoundWarning, match="below nmax = 1000"):
        moli.identify_kernel_arx(*records, nmax=1000)


def test_a_duplicated_input_is_called_collinear_not_unexcited():
    record = moli.example_data(N=400, seed=3)
    doubled = moli.IOData(record.y, np.column_stack([record.u, record.u[:, 1]]))
    assert [issue.kind for issue in moli.check_data(doubled, nmax=6)] == ["collinear"]


def test_identify_warns_that_a_sampled_model_takes_uneven_stamps_as_even():
    record = moli.example_data(N=400, seed=3)
    stamps = np.arange(400.0)
    stamps[200:] += 2.0                  # one step of 3 Ts: the model would take it as one
    with pytest.warns(moli.IrregularSamplingWarning, match="1 step of the record's time stamps differ"):
        moli.identify(moli.IOData(record.y, record.u, times=stamps), nmax=3)


@pytest.mark.parametrize("method", [moli.identify, moli.identify_kernel, moli.identify_kernel_arx])
def test_a_validation_record_of_one_sample_is_refused_by_name_before_any_work(records, method):
    with pytest.raises(moli.DataError, match="validation holds 1 sample"):
        method(records[0], records[1][:1], nmax=3)


def test_a_continuous_model_with_input_delays_is_scored_as_its_sampled_form():
    sampled = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).with_input_delays([2])
    u = np.random.default_rng(0).standard_normal(200)
    record = moli.IOData(sampled.simulate(u), u)
    continuous = sampled.to_continuous()          # a delay of 2 time units: it refused to be scored
    # the same model by two conversions: equal to round-off of the logarithm and exponential of A
    np.testing.assert_allclose(moli.compare(continuous, record).yhat, moli.compare(sampled, record).yhat,
                               atol=1e-12)
    stamps = np.arange(200.0)
    stamps[100:] += 0.5
    with pytest.raises(moli.DataError, match="evenly sampled records only"):
        moli.compare(continuous, moli.IOData(record.y, record.u, times=stamps))
