"""Continuous-time identification against known continuous plants (docs/continuous.md)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

import moli
from moli.errors import DataError, OptionError
from moli.method.continuous.estimation import observer_rows, stamped_record
from moli.method.continuous.filters import unit_divisors, unit_roots
from moli.models.bands import magnitude_bands
from moli.models.continuous import ContinuousModel, discretize
from moli.models.propagation import propagate

# A 2x2 plant of order 4 (poles -1, -2 +- 3j, -5) in modal form.
A_TRUE = scipy.linalg.block_diag([[-1.0]], [[-2.0, 3.0], [-3.0, -2.0]], [[-5.0]])
B_TRUE = np.array([[1.0, 0.5], [0.8, -0.6], [0.3, 1.0], [3.0, 2.0]])
C_TRUE = np.array([[1.0, 0.6, -0.4, 0.5], [0.3, -0.8, 1.2, 0.4]])
POLES = np.linalg.eigvals(A_TRUE)


def held_binary(N: int, seed: int, m: int = 2, mean_hold: int = 60) -> np.ndarray:
    """Random binary inputs held for exponentially distributed numbers of samples."""
    rng = np.random.default_rng(seed)
    u = np.empty((N, m))
    for j in range(m):
        k = 0
        while k < N:
            span = 1 + int(rng.exponential(mean_hold))
            u[k : k + span, j] = rng.choice([-1.0, 1.0])
            k += span
    return u


def sampled(t: np.ndarray, u: np.ndarray, A=A_TRUE, B=B_TRUE, C=C_TRUE) -> np.ndarray:
    """Exact samples of the plant from rest with the input held between stamps."""
    x = np.zeros(A.shape[0])
    y = np.empty((t.size, C.shape[0]))
    for k in range(t.size):
        y[k] = C @ x
        if k + 1 < t.size:
            Ad, Bd, _, _ = discretize(A, B, C, np.zeros((C.shape[0], B.shape[1])), t[k + 1] - t[k])
            x = Ad @ x + Bd @ u[k]
    return y


def stamped(y: np.ndarray, u: np.ndarray, t: np.ndarray, at: float = 0.7) -> tuple[moli.IOData, moli.IOData]:
    """Estimation and validation records with the stamps ``t``: the first ``at`` of the samples, the rest."""
    return moli.IOData(y, u, times=t).split(at) if at < 1 else (moli.IOData(y, u, times=t), None)


def pole_errors(estimated: np.ndarray, true: np.ndarray = POLES) -> np.ndarray:
    return np.array([np.min(np.abs(estimated - p)) / abs(p) for p in true])


@pytest.mark.parametrize("irregular", [False, True])
@pytest.mark.parametrize("linear", [False, True])
def test_propagation_matches_an_ode_solver(irregular, linear):
    rng = np.random.default_rng(3)
    F = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-6.0, -11.0, -6.0]])
    G = np.array([[0.0], [0.0], [1.0]])
    N = 60
    h = 0.05 * (rng.uniform(0.5, 1.5, N - 1) if irregular else np.ones(N - 1))
    t = np.concatenate([[0.0], np.cumsum(h)])
    v = rng.standard_normal(N)
    states = propagate(F, G, t, v[:, None, None], np.array([[linear]]), start=np.ones((3, 1)))[:, :, 0]

    def drive(time, k):
        return v[k] + (v[k + 1] - v[k]) * (time - t[k]) / h[k] if linear else v[k]

    x = np.ones(3)
    for k in range(N - 1):
        x = scipy.integrate.solve_ivp(lambda s, z: F @ z + G[:, 0] * drive(s, k), (t[k], t[k + 1]), x,
                                      method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        # the solver's tolerance is 1e-12; the maps come from one matrix exponential each
        assert np.allclose(states[k + 1], x, rtol=1e-9, atol=1e-11)


def test_a_repeated_pole_takes_the_exponential_of_each_interval():
    F = np.array([[0.0, 1.0], [-1.0, -2.0]])              # (s + 1)^2: no eigenvector basis
    t = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.05, 0.15, 30)])
    states = propagate(F, np.zeros((2, 1)), t, np.zeros((t.size, 1, 2)), np.zeros((1, 2), bool),
                       start=np.eye(2))
    expected = np.stack([scipy.linalg.expm(F * s) for s in t])
    assert np.allclose(states, expected, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("indices", [(1,), (2, 1), (2, 2), (3, 1, 2), (4, 3), (5, 2)])
@pytest.mark.parametrize("zeta", [0.6, 0.9, 1.1])
def test_filters_are_stable_and_their_divisors_divide_them(indices, zeta):
    roots = unit_roots(zeta, indices, 2.0)
    assert roots.size == max(indices) and np.all(roots.real < 0)
    # distinct roots: every filter has a basis of eigenvectors
    assert np.min(np.abs(roots[:, None] - roots[None, :]) + np.eye(roots.size)) > 1e-3
    alpha, *divisors = unit_divisors(zeta, indices, 2.0)
    for l, divisor in zip(indices, divisors):
        assert divisor.size == l + 1
        remainder = np.polydiv(alpha, divisor)[1]
        assert np.max(np.abs(remainder)) < 1e-12 * np.max(np.abs(alpha))


def test_the_filtered_regressors_are_the_filters_applied_to_the_signals():
    rng = np.random.default_rng(0)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.015, 299)])
    u = held_binary(300, 0, m=1, mean_hold=20)
    y = rng.standard_normal((300, 1))
    record = stamped_record(stamped(y, u, t, at=1.0)[0])
    wc, alpha = 3.0, unit_divisors(0.7, (2,), 2.0)[0]
    rows = observer_rows(record, wc, alpha, linear_inputs=False, skip=0)[0]
    # columns r*nbar + t hold s^t/alpha(s) of channel r (time in units of 1/wc): check
    # the input channel against the ODE solved with the input held
    F = np.array([[0.0, 1.0], [-alpha[2], -alpha[1]]])
    x = np.zeros(2)
    for k in range(t.size - 1):
        assert np.allclose(rows[k, 2:4], x, rtol=1e-9, atol=1e-12)
        x = scipy.integrate.solve_ivp(lambda s, z: F @ z + np.array([0.0, u[k, 0]]),
                                      (wc * t[k], wc * t[k + 1]), x, method="DOP853",
                                      rtol=1e-12, atol=1e-14).y[:, -1]


def test_noise_free_poles_converge_as_the_sampling_period_shrinks():
    errors = []
    for T in (0.02, 0.01):
        t = np.arange(int(12 / T)) * T
        u = held_binary(t.size, 1, mean_hold=int(0.1 / T))
        result = moli.identify(moli.IOData(sampled(t, u), u, Ts=T), time="continuous", order=4,
                               omega=[(6.0, 0.7)])
        errors.append(np.max(pole_errors(result.model.poles())))
    # held inputs are exact and the outputs' linear interpolation errs by O(T^2): halving
    # T cuts the error by about 4, well over the factor 2 of a first-order error (the
    # records are centred on their means, which the constant channel takes up)
    assert errors[0] < 0.005 and errors[1] < errors[0] / 3


def test_an_irregular_record_with_gaps_finds_the_order_and_the_poles():
    rng = np.random.default_rng(7)
    h = rng.uniform(0.5, 1.5, 5999) * 5e-3
    h[[2000, 4000]] = 0.3                                  # two gaps: three segments
    t = np.concatenate([[0.0], np.cumsum(h)])
    u = held_binary(t.size, 2, mean_hold=20)
    y = sampled(t, u)
    y = y + 0.01 * np.std(y, axis=0) * np.random.default_rng(8).standard_normal(y.shape)   # 40 dB
    estimation, validation = stamped(y, u, t)
    assert len(stamped_record(estimation).times) == 3
    result = moli.identify(estimation, validation, time="continuous", nmax=6, order_rule="paired")
    assert result.selected.order == 4
    # 40 dB on 6000 samples: the poles are known to a few tenths of a percent; 3 % is
    # the irregular-sampling target of docs/continuous.md
    assert np.max(pole_errors(result.model.poles())) < 0.03


def test_gain_bands_match_the_spread_over_records():
    A, B, C = np.array([[-2.0]]), np.array([[2.0]]), np.array([[1.5]])      # static gain 1.5
    gains, bounds = [], []
    for seed in range(30):
        t = np.arange(1500) * 0.01
        u = held_binary(t.size, seed, m=1, mean_hold=30)
        y = sampled(t, u, A, B, C) + 0.1 * np.random.default_rng(100 + seed).standard_normal((t.size, 1))
        model = moli.identify(moli.IOData(y, u, Ts=0.01), time="continuous", order=1,
                              omega=[(2.0, 1.1)]).model
        gains.append(model.static_gain()[0, 0])
        lower, upper = magnitude_bands(model, [0.0])
        bounds.append((upper[0, 0, 0] - lower[0, 0, 0]) / (2 * 1.96))
    spread = np.std(gains, ddof=1)
    # 30 records estimate a standard deviation to about +-13 % (1/sqrt(2 x 29)): a
    # factor 1.5 either way flags a wrong covariance, not sampling noise
    assert 1 / 1.5 < np.median(bounds) / spread < 1.5
    assert abs(np.mean(gains) - 1.5) < 3 * spread / np.sqrt(30) + 1e-3


def test_a_continuous_model_saves_loads_and_converts(tmp_path):
    t = np.arange(3000) * 0.01
    u = held_binary(t.size, 4)
    y = sampled(t, u) + 1e-3 * np.random.default_rng(4).standard_normal((t.size, 2))
    model = moli.identify(moli.IOData(y, u, Ts=0.01), time="continuous", order=4).model
    assert model.cov_factor is not None
    model.save(tmp_path / "model.json")
    loaded = moli.load_model(tmp_path / "model.json")
    assert isinstance(loaded, ContinuousModel)
    assert np.array_equal(loaded.A, model.A) and np.array_equal(loaded.cov_factor, model.cov_factor)
    stamps = np.cumsum(np.r_[0.0, np.random.default_rng(2).uniform(0.005, 0.015, 499)])
    inputs = held_binary(500, 5)
    assert np.allclose(loaded.simulate(inputs, stamps), sampled(stamps, inputs, model.A, model.B, model.C),
                       rtol=1e-9, atol=1e-9)
    assert np.allclose(np.sort_complex(model.to_discrete(0.01).poles()),
                       np.sort_complex(np.exp(model.poles() * 0.01)), atol=1e-9)
    assert "natural frequency" in "\n".join(model.pole_table())


def test_bad_continuous_inputs_get_clear_errors():
    t = np.arange(400) * 0.01
    u = held_binary(t.size, 1)
    y = sampled(t, u)
    backwards = t.copy()
    backwards[100] = backwards[99]
    with pytest.raises(DataError, match="100"):
        moli.identify(moli.IOData(y, u, times=backwards), time="continuous", nmax=4)
    with pytest.raises(OptionError, match="refined"):
        moli.identify(moli.IOData(y, u, Ts=0.01), time="continuous", order_rule="refined")
    with pytest.raises(OptionError, match="zoom"):
        moli.identify(moli.IOData(y, u, Ts=0.01), time="continuous", tuning="zoom")
    model = ContinuousModel(np.array([[-1.0]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)),
                            ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,))
    with pytest.raises(DataError, match="time stamps"):
        model.simulate(np.ones(5))
    with pytest.raises(DataError, match="not a sampling period"):
        model.simulate(np.ones(5), 0.1)
    with pytest.raises(DataError, match="increase"):
        model.simulate(np.ones(3), [0.0, 2.0, 1.0])


def test_a_segment_too_short_for_the_filter_gives_no_rows_and_no_error():
    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.015, 1499)])
    t[1000:] += 1.0                                        # a gap ...
    t[1002:] += 1.0                                        # ... and another: a 2-sample segment
    u = held_binary(t.size, 6, mean_hold=20)
    y = sampled(t, u)
    y = y + 0.01 * np.std(y, axis=0) * np.random.default_rng(9).standard_normal(y.shape)
    estimation, validation = stamped(y, u, t)
    assert [s.size for s in stamped_record(estimation).times] == [1000, 2, 48]
    model = moli.identify(estimation, validation, time="continuous", order=4).model
    assert np.all(np.isfinite(model.cov_factor))


def test_an_offset_record_is_fitted_whole_and_its_errors_are_the_noise():
    A, B, C = np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]])
    t = np.arange(2000) * 0.01
    u = 1.0 + held_binary(t.size, 3, m=1, mean_hold=40)    # a mean of 1 from rest: not an equilibrium
    y = sampled(t, u, A, B, C)
    result = moli.identify(*stamped(y, u, t), time="continuous", order=1)
    # noise-free: the validation errors, offset included, are round-off and the O(T^2)
    # interpolation (the plant's own offset is not in the simulation without the fitted constant)
    assert np.sum(result.selected.errors) < 1e-3
    assert abs(result.model.poles()[0] + 1.0) < 1e-3


def test_options_of_the_discrete_method_are_refused_in_continuous_time():
    t = np.arange(400) * 0.01
    u = held_binary(t.size, 1)
    data = moli.IOData(sampled(t, u), u, Ts=0.01)
    with pytest.raises(OptionError, match="feedthrough=True"):
        moli.identify(data, time="continuous", feedthrough=True)
    with pytest.raises(OptionError, match="at least the number of outputs"):
        moli.identify(data, time="continuous", order=1)
    with pytest.raises(OptionError, match="continuous time only"):
        moli.identify(data, input_hold="foh")


def test_a_jittered_file_is_identified_across_the_readers_cuts(tmp_path):
    rng = np.random.default_rng(11)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.5, 1.5, 2999) * 5e-3])
    u = held_binary(t.size, 12, mean_hold=20)
    y = sampled(t, u)
    y = y + 0.01 * np.std(y, axis=0) * rng.standard_normal(y.shape)
    path = tmp_path / "jittered.csv"
    path.write_text("time,u1,u2,y1,y2\n" + "\n".join(
        ",".join(f"{v:.17g}" for v in row) for row in np.column_stack([t, u, y])))
    with pytest.warns(moli.IrregularSamplingWarning):
        data = moli.read_data(path, inputs=["u1", "u2"], outputs=["y1", "y2"])
    # the reader cuts at every step over 1.5 of its period (a sampled model's gaps)
    assert data.n_segments > 10
    assert len(stamped_record(data).times) == 1
    result = moli.identify(data, time="continuous", nmax=6)
    assert result.selected.order == 4
    # 40 dB on 2,100 estimation samples: a few tenths of a percent; 3 % as the
    # irregular-sampling target of docs/continuous.md
    assert np.max(pole_errors(result.model.poles())) < 0.03


def test_a_short_validation_record_scores_every_order_on_the_same_samples():
    t = np.arange(200) * 0.05
    u = held_binary(t.size, 13, mean_hold=4)
    y = sampled(t, u) + 0.01 * np.random.default_rng(14).standard_normal((t.size, 2))
    # 30 validation samples: a fifth is 6, fewer than a high order's initial state needs,
    # so the warm-up follows the path's end and the paired rule compares equal samples
    result = moli.identify(*stamped(y, u, t, at=0.85), time="continuous", nmax=10)
    assert len({st.errors.size for st in result.path}) == 1


def test_identify_records_the_options_and_hold_on_a_continuous_model():
    # a direct call, not only the command line, leaves the model what made it: a model fitted
    # with linear inputs is then simulated with linear inputs by compare
    data = moli.example_data(N=400, seed=3)
    result = moli.identify(data, time="continuous", nmax=4, input_hold="foh")
    assert result.model.input_hold == "foh"
    assert result.model.info["options"]["time"] == "continuous"
    assert result.model.info["options"]["input_hold"] == "foh"
    np.testing.assert_allclose(result.model.info["validation_vaf"], result.selected.vaf)


def test_a_continuous_model_of_noise_says_it_fits_no_output():
    rng = np.random.default_rng(1)
    noise = moli.IOData(rng.standard_normal((120, 1)), rng.standard_normal((120, 1)), 0.1)
    with pytest.warns(moli.NoFitWarning, match="output y1 no better than its mean"):
        moli.identify(noise, time="continuous", nmax=3)
