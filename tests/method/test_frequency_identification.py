"""identify() on FrequencyData (docs/frequency.md): exact recovery, accuracy under noise, options, covariance, modes."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import DataError, FrequencyData, OptionError
from moli.method.frequency.orders import fit_domain


def modal_system(frequencies, dampings, p, m, seed):
    """A continuous model with one lightly damped mode per natural frequency, random B and C."""
    blocks = []
    for wn, zeta in zip(frequencies, dampings):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        blocks.append(np.array([[sigma, omega], [-omega, sigma]]))
    n = 2 * len(blocks)
    A = np.zeros((n, n))
    for i, block in enumerate(blocks):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = block
    rng = np.random.default_rng(seed)
    return moli.ContinuousModel(A, rng.standard_normal((n, m)), rng.standard_normal((p, n)), np.zeros((p, m)),
                                tuple(f"y{i + 1}" for i in range(p)), tuple(f"u{j + 1}" for j in range(m)),
                                np.zeros(p), np.zeros(m), (0.0,) * m)


def sorted_poles(model):
    poles = np.linalg.eigvals(model.A)
    return poles[np.lexsort((poles.imag, poles.real))]


FREQUENCIES = np.array([10.0, 23.0, 41.0, 77.0])
DAMPINGS = np.array([0.005, 0.02, 0.01, 0.05])
OMEGA = np.logspace(0, 2.5, 2000)


def noisy(truth, omega, level, seed, Ts=None):
    """FRF of ``truth`` with circular complex noise of ``level`` times |G| on each entry, and that variance."""
    G = truth.frequency_response(omega)
    rng = np.random.default_rng(seed)
    spread = level * np.abs(G)
    noise = spread * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
    return FrequencyData(omega, G + noise, unit="rad/s", Ts=Ts, variance=spread**2)


# --- exact recovery ---------------------------------------------------------------------------

# Noise-free lines: the subspace start is exact up to round-off and the refinement keeps it;
# 1e-8 leaves the round-off of eigenvalues of up to 10 states (1e-12 relative here) a wide margin.
EXACT = 1e-8


@pytest.mark.parametrize("p, m, modes", [(1, 1, 2), (3, 2, 4)])
def test_a_continuous_systems_noise_free_response_gives_back_its_poles_and_response(p, m, modes):
    truth = modal_system(FREQUENCIES[:modes], DAMPINGS[:modes], p, m, seed=12)
    result = moli.identify(FrequencyData(OMEGA, truth.frequency_response(OMEGA), unit="rad/s"))
    model = result.model
    assert isinstance(model, moli.ContinuousModel) and model.n == 2 * modes
    assert np.allclose(sorted_poles(model), sorted_poles(truth), rtol=EXACT, atol=0)
    fitted, G = model.frequency_response(OMEGA), truth.frequency_response(OMEGA)
    assert np.max(np.abs(fitted - G)) <= EXACT * np.max(np.abs(G))


@pytest.mark.parametrize("p, m, modes", [(1, 1, 2), (3, 2, 4)])
def test_a_sampled_systems_noise_free_response_gives_back_its_poles_and_response(p, m, modes):
    truth = modal_system(FREQUENCIES[:modes], DAMPINGS[:modes], p, m, seed=5).to_discrete(0.01)
    omega = np.logspace(0, np.log10(np.pi / 0.01), 1500)
    result = moli.identify(FrequencyData(omega, truth.frequency_response(omega), unit="rad/s", Ts=0.01))
    model = result.model
    assert isinstance(model, moli.StateSpaceModel) and model.Ts == 0.01 and model.n == 2 * modes
    assert np.allclose(sorted_poles(model), sorted_poles(truth), rtol=EXACT, atol=0)
    fitted, G = model.frequency_response(omega), truth.frequency_response(omega)
    assert np.max(np.abs(fitted - G)) <= EXACT * np.max(np.abs(G))


def test_a_feedthrough_and_a_real_pole_are_recovered_too():
    A = np.array([[-0.5, 3.0, 0.0], [-3.0, -0.5, 0.0], [0.0, 0.0, -2.0]])
    truth = moli.ContinuousModel(A, np.array([[1.0], [0.5], [2.0]]), np.array([[1.0, -1.0, 0.5]]), np.array([[0.3]]),
                                 ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,))
    omega = np.logspace(-1, 2, 400)
    model = moli.identify(FrequencyData(omega, truth.frequency_response(omega), unit="rad/s")).model
    assert np.allclose(sorted_poles(model), sorted_poles(truth), rtol=EXACT) and np.allclose(model.D, 0.3, rtol=EXACT)


# --- accuracy under noise ---------------------------------------------------------------------

@pytest.mark.parametrize("seed, level", [(0, 0.01), (1, 0.03), (2, 0.02)])
def test_modes_of_a_noisy_mimo_modal_response(seed, level):
    # 2000 lines, 1-3 % noise: the refinement's standard error of a natural frequency is
    # about level * zeta / sqrt(lines near the peak) (1e-4 relative, docs/frequency.md measures
    # 20 seeds), so 0.2 % and 10 % of the damping are the accuracy an engineer asks for, met
    # with room; the order must be the true one.
    truth = modal_system(FREQUENCIES, DAMPINGS, 3, 2, seed=12)
    result = moli.identify(noisy(truth, OMEGA, level, seed))
    assert result.selected.order == 8 and result.model.n == 8
    found = moli.modes(result.model)
    assert len(found) == 4 and all(mode.oscillatory for mode in found)
    natural = np.array([mode.natural_frequency for mode in found])
    damping = np.array([mode.damping for mode in found])
    assert np.all(np.abs(natural / FREQUENCIES - 1) < 0.002)
    assert np.all(np.abs(damping / DAMPINGS - 1) < 0.10)


def test_an_order_that_misses_the_modes_of_one_part_of_the_band_is_not_taken():
    # modes gathered in the upper half of the band: an order too low errs only there; the paired
    # rule must see that loss as the band-wide batches give it, not as one batch's outlier
    frequencies, dampings = np.array([39.4, 59.8, 79.5, 111.5]), np.array([0.017, 0.043, 0.033, 0.005])
    truth = modal_system(frequencies, dampings, 3, 2, seed=21)
    result = moli.identify(noisy(truth, np.logspace(0, np.log10(300), 2000), 0.02, 3))
    assert result.selected.order == 8


def test_periodic_records_averaged_into_a_response_give_the_modes():
    # the chain from time records: a multisine of 8192 samples (lines 0.077 rad/s apart, 8-10
    # per half-power band of the 23 and 41 rad/s modes), five noisy periods in steady state,
    # the first dropped; output noise 2 % of the output's spread on every sample
    truth = modal_system(FREQUENCIES[1:3], DAMPINGS[1:3], 2, 1, seed=6).to_discrete(0.01)
    length, lines = 8192, np.arange(1, 1200)
    phases = np.random.default_rng(2).uniform(0, 2 * np.pi, lines.size)
    period = np.cos(2 * np.pi * np.outer(np.arange(length), lines) / length + phases).sum(axis=1)
    u = np.tile(period, 10)[:, None]
    y = truth.simulate(u)[5 * length:]          # five periods for the lightly damped modes to settle
    y = y + 0.02 * y.std(axis=0) * np.random.default_rng(3).standard_normal(y.shape)
    frf = moli.frequency_response(moli.IOData(y, u[5 * length:], Ts=0.01), 5)
    result = moli.identify(frf)
    assert result.selected.order == 4
    found = moli.modes(result.model)
    assert np.allclose([mode.natural_frequency for mode in found], FREQUENCIES[1:3], rtol=0.002)
    assert np.allclose([mode.damping for mode in found], DAMPINGS[1:3], rtol=0.10)


def test_a_sampled_noisy_response_has_its_bands_and_they_hold_the_truth():
    # 95 % pointwise bands from the sandwich. One record's lines err together (a mode's frequency
    # off moves every line near its peak), so the share of lines whose band holds the true gain
    # scatters from record to record (0.64-1.00 over 12 seeds, sd about 0.12); its mean over six
    # records spreads by about 0.05. 0.80-0.99 is 2-3 of those below and above the 0.91 measured
    # over 12 records, and excludes bands half as wide (0.68 per line at best) or twice as wide
    # (0.9999 per line).
    truth = modal_system(FREQUENCIES[:2], DAMPINGS[:2], 2, 1, seed=3).to_discrete(0.01)
    omega = np.logspace(0, np.log10(np.pi / 0.01), 1500)
    gain = np.abs(truth.frequency_response(omega))
    held = []
    for seed in range(6):
        model = moli.identify(noisy(truth, omega, 0.02, seed, Ts=0.01)).model
        lower, upper = model.magnitude_bands(omega)
        held.append(np.mean((lower <= gain) & (gain <= upper)))
    assert 0.80 <= np.mean(held) <= 0.99


# --- options and bad calls --------------------------------------------------------------------

SMALL = modal_system(FREQUENCIES[:1], DAMPINGS[:1], 1, 1, seed=1)
SMALL_DATA = FrequencyData(OMEGA[::10], SMALL.frequency_response(OMEGA[::10]), unit="rad/s")


def test_a_fixed_order_is_the_only_order_fitted():
    result = moli.identify(SMALL_DATA, order=3)
    assert [step.order for step in result.path] == [3] and result.model.n == 3


def test_the_paths_orders_are_judged_on_interleaved_held_out_lines():
    result = moli.identify(SMALL_DATA, nmax=4)
    assert [step.order for step in result.path] == [1, 2, 3, 4] and result.selected.order == 2
    assert np.all(np.diff(result.held_out) == 5) and result.held_out[-1] >= SMALL_DATA.F - 5


def test_refine_none_keeps_the_subspace_start_and_selected_refines_only_the_chosen_order():
    seen = []
    start = moli.identify(SMALL_DATA, nmax=3, refine="none", progress=seen.append)
    assert [step.order for step in seen] == [1, 2, 3] and not any(step.refined for step in seen)
    assert start.model.cov_factor is None and "refine='none'" in start.covariance_note
    selected = moli.identify(SMALL_DATA, nmax=3, refine="selected")
    assert not any(step.refined for step in selected.path) and selected.model.cov_factor is not None


def test_an_unstable_system_is_fitted_as_it_is_when_max_radius_is_none_and_mirrored_by_default():
    unstable = moli.ContinuousModel(np.array([[0.2, 5.0], [-5.0, 0.2]]), np.array([[1.0], [0.0]]),
                                    np.array([[1.0, 1.0]]), np.zeros((1, 1)), ("y1",), ("u1",), np.zeros(1),
                                    np.zeros(1), (0.0,))
    omega = np.logspace(-1, 2, 300)
    data = FrequencyData(omega, unstable.frequency_response(omega), unit="rad/s")
    with pytest.warns(moli.UnstableModelWarning, match="unstable") as caught:
        free = moli.identify(data, max_radius=None, order=2).model
    assert caught[0].filename == __file__           # it points at the caller of identify
    assert np.allclose(sorted_poles(free), sorted_poles(unstable), rtol=EXACT)
    assert moli.identify(data, order=2).model.is_stable()


@pytest.mark.parametrize("overrides, message", [
    ({"filter_grid": "paper"}, "filter_grid does not apply to frequency data"),
    ({"order_rule": "tolerance"}, "order_rule 'tolerance' does not apply"),
    ({"max_radius": "auto"}, "max_radius='auto'"),
    ({"time": "continuous"}, None),
])
def test_options_of_the_time_domain_method_are_refused_by_name(overrides, message):
    if message is None:     # continuous data with time="continuous": the data's own time base
        assert moli.identify(SMALL_DATA, order=2, **overrides).model.n == 2
        return
    with pytest.raises(OptionError, match=message):
        moli.identify(SMALL_DATA, **overrides)


def test_time_continuous_on_sampled_data_and_a_validation_record_are_refused():
    sampled = FrequencyData([1.0, 2.0, 3.0], [1, 1, 1], unit="rad/s", Ts=0.1)
    with pytest.raises(OptionError, match="give Ts"):
        moli.identify(sampled, time="continuous")
    with pytest.raises(OptionError, match="validation does not apply"):
        moli.identify(SMALL_DATA, SMALL_DATA)


def test_too_few_lines_for_the_orders_is_a_data_error():
    with pytest.raises(DataError, match="too few for models of up to 10 states"):
        moli.identify(FrequencyData(OMEGA[:12], SMALL.frequency_response(OMEGA[:12]), unit="rad/s"))


# --- modes ------------------------------------------------------------------------------------

def test_modes_of_a_continuous_model_and_of_its_sampled_twin_agree():
    truth = modal_system(FREQUENCIES[:2], DAMPINGS[:2], 2, 1, seed=4)
    for model in (truth, truth.to_discrete(0.01)):
        found = moli.modes(model)
        assert np.allclose([mode.natural_frequency for mode in found], FREQUENCIES[:2], rtol=1e-10)
        assert np.allclose([mode.damping for mode in found], DAMPINGS[:2], rtol=1e-8)
        assert np.allclose([mode.frequency_hz for mode in found], FREQUENCIES[:2] / (2 * np.pi), rtol=1e-10)
    # the shape of mode i is C v_i: the pair's columns of C as one complex vector, largest entry 1
    shape = truth.C[:, 0] + 1j * truth.C[:, 1]
    shape = shape / shape[np.argmax(np.abs(shape))]
    assert np.allclose(moli.modes(truth)[0].shape, shape, rtol=1e-10)


def test_a_real_pole_is_one_mode_critically_damped_and_a_delay_state_has_none():
    model = moli.StateSpaceModel([[0.5]], [[1.0]], [[2.0]], Ts=0.1)
    (mode,) = moli.modes(model)
    assert not mode.oscillatory and np.isclose(mode.damping, 1.0)
    assert np.isclose(mode.natural_frequency, np.log(2) / 0.1)        # |ln 0.5| / Ts
    with pytest.raises(DataError, match="pole at z = 0"):
        moli.modes(moli.StateSpaceModel([[0.0]], [[1.0]], [[1.0]]))


def _fitted_and_drawn(Ts: float | None, outputs: int, seed: int) -> tuple:
    """The truth, a model fitted to its noisy response, and the modes of 4000 models drawn from that
    model's covariance (A, B, C and D together)."""
    truth = modal_system(FREQUENCIES[:2], DAMPINGS[:2], outputs, 1, seed=4)
    omega = np.logspace(0, 2, 500)
    plant = truth if Ts is None else truth.to_discrete(Ts)
    model = moli.identify(noisy(plant, omega, 0.02, 5, Ts=Ts)).model
    n, m, p = model.n, model.m, model.p
    nominal = np.concatenate([model.A.ravel(), model.B.ravel(), model.C.ravel(), model.D.ravel()])
    draws = nominal + np.random.default_rng(seed).standard_normal((4000, model.cov_factor.shape[1])) \
        @ model.cov_factor.T
    drawn = []
    for vector in draws:
        A, B, C, D = np.split(vector, np.cumsum([n * n, n * m, p * n]))
        matrices = (A.reshape(n, n), B.reshape(n, m), C.reshape(p, n), D.reshape(p, m))
        drawn.append(moli.modes(moli.ContinuousModel(*matrices, model.output_names, model.input_names, np.zeros(p),
                                                     np.zeros(m), (0.0,) * m) if Ts is None
                                else moli.StateSpaceModel(*matrices, Ts)))
    return truth, model, drawn


@pytest.mark.parametrize("Ts", [None, 0.01])
def test_the_modes_standard_deviations_are_those_of_the_covariances_draws(Ts):
    # first-order spreads against the spread of the modes of 4000 models drawn from the same
    # covariance: the sample's standard deviation is off by 1/sqrt(2 x 4000) = 1.1 % of itself,
    # and the linearization by far less at a relative spread of 1e-4, so 5 % is 4.5 standard errors
    truth, model, drawn = _fitted_and_drawn(Ts, 2, seed=8)
    for i, mode in enumerate(moli.modes(model)):
        natural = np.std([modes[i].natural_frequency for modes in drawn])
        damping = np.std([modes[i].damping for modes in drawn])
        assert mode.natural_frequency_std == pytest.approx(natural, rel=0.05)
        assert mode.damping_std == pytest.approx(damping, rel=0.05)
    assert moli.modes(truth)[0].natural_frequency_std is None


@pytest.mark.parametrize("Ts", [None, 0.01])
def test_the_mode_shapes_standard_deviations_are_those_of_the_covariances_draws(Ts):
    # as the test above, for the shapes (they move with A's eigenvector and with C), 3 outputs
    truth, model, drawn = _fitted_and_drawn(Ts, 3, seed=9)
    shapes = np.array([[mode.shape for mode in modes] for modes in drawn])
    for i, mode in enumerate(moli.modes(model)):
        reference = np.argmax(np.abs(mode.shape))
        # each draw scaled to its entry of the model's reference output (a draw's own largest entry
        # may be another output where two are close: the shape is the same up to that complex scale)
        scaled = shapes[:, i] / shapes[:, i, reference, None]
        others = np.arange(model.p) != reference
        np.testing.assert_allclose(mode.shape_magnitude_std[others], np.abs(scaled).std(axis=0)[others], rtol=0.05)
        np.testing.assert_allclose(mode.shape_phase_std[others], np.angle(scaled / mode.shape).std(axis=0)[others],
                                   rtol=0.05)
        assert mode.shape_magnitude_std[reference] == 0 and mode.shape_phase_std[reference] == 0
    assert moli.modes(truth)[0].shape_magnitude_std is None


@pytest.mark.parametrize("spacing", ["log", "even"])
def test_the_discrete_subspace_start_maps_the_spread_circle_back_onto_the_lines(spacing):
    """A model on the spread circle ``w = (z + a) / (1 + a z)`` maps back to the poles it came from."""
    Ts = 0.01
    omega = (np.logspace(0, np.log10(np.pi / Ts), 500) if spacing == "log"
             else np.linspace(np.pi / Ts / 500, np.pi / Ts, 500))
    data = moli.FrequencyData(omega, np.ones((500, 1, 1)), unit="rad/s", Ts=Ts)
    domain = fit_domain(data)
    z = np.exp(1j * omega * Ts)
    w = domain.circle(data)
    np.testing.assert_allclose(np.abs(w), 1, atol=1e-12)                   # the circle onto itself
    if spacing == "even":
        # the Tustin frequencies tan(theta / 2) of lines even in theta have a geometric mean near 1
        # (tan and cot pair up about pi / 2): next to no map
        assert abs(domain.spread) < 0.05
    else:
        # half the log-spaced lines lie below a tenth of the Nyquist frequency; spread, they straddle w = j
        assert np.median(np.angle(z)) < np.pi / 10 and 0.3 < np.mean(np.angle(w) < np.pi / 2) < 0.7
    poles = np.array([0.999, 0.95 * np.exp(0.2j), 0.95 * np.exp(-0.2j), -0.5])
    A = np.diag(poles)
    a = domain.spread
    on_circle = np.linalg.solve(np.eye(4) + a * A, A + a * np.eye(4))       # each pole z to (z + a) / (1 + a z)
    A_back, C_back = domain.from_circle(on_circle, np.ones((1, 4)))
    # eigenvalues of a 4 x 4 map of condition near 1: round-off
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A_back)), np.sort_complex(poles), atol=1e-12)
    assert C_back.shape == (1, 4)


def test_the_zero_and_nyquist_lines_leave_the_spread_of_the_others_alone():
    # both are fixed points of every map of the family (z = 1 and z = -1); the Nyquist line as a
    # column printed with six digits gives it (314.159, 8e-7 below pi / Ts) must not count either
    Ts = 0.01
    inside = np.logspace(0, 2, 300)
    scales = []
    for ends in ([], [0.0], [np.pi / Ts], [314.159], [0.0, np.pi / Ts]):
        omega = np.sort(np.concatenate([inside, ends]))
        scales.append(fit_domain(FrequencyData(omega, np.ones((omega.size, 1, 1)), unit="rad/s", Ts=Ts)).scale)
    np.testing.assert_allclose(scales, scales[0], rtol=1e-12)       # the same lines: round-off only
