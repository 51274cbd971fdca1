import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import dlsim

import moli
from moli.models.simulation import simulate_batch

from systems_util import random_system


@settings(max_examples=40, deadline=None)
@given(N=st.integers(1, 700), n=st.integers(1, 6), seed=st.integers(0, 10_000))
def test_block_simulation_matches_sample_loop(N, n, seed):
    rng = np.random.default_rng(seed)
    system = random_system(n, 2, 2, rng)
    u = rng.standard_normal((N, 2))
    x0 = rng.standard_normal(n)
    _, expected, _ = dlsim((system.A, system.B, system.C, system.D, 1.0), u, x0=x0)
    got = system.simulate(u, x0)
    # same arithmetic regrouped into block products: agreement to round-off
    np.testing.assert_allclose(got, expected.reshape(N, 2), atol=1e-9 * (1 + np.abs(expected).max()))


def test_batch_simulation_is_per_model():
    rng = np.random.default_rng(1)
    systems = [random_system(3, 1, 2, rng) for _ in range(4)]
    u = rng.standard_normal((90, 2))
    batch = simulate_batch(
        np.stack([s.A for s in systems]), np.stack([s.B for s in systems]), np.stack([s.C for s in systems]), u
    )
    for r, s in enumerate(systems):
        np.testing.assert_allclose(batch[r], s.simulate(u), atol=1e-12)


def test_poles_stability_markov():
    model = moli.StateSpaceModel([[0.5, 1.0], [0.0, -0.2]], [[0.0], [1.0]], [[1.0, 0.0]])
    np.testing.assert_allclose(sorted(model.poles().real), [-0.2, 0.5])
    assert model.is_stable()
    np.testing.assert_allclose(model.markov(3)[:, 0, 0], [0.0, 0.0, 1.0])
    assert not moli.StateSpaceModel([[1.01]], [[1.0]], [[1.0]]).is_stable()


def test_save_load_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    model = random_system(4, 2, 3, rng)
    model.indices = (2, 2)
    model.info["wc"] = 0.3
    path = tmp_path / "model.json"
    model.save(path)
    loaded = moli.load_model(path)
    for name in "ABCD":
        np.testing.assert_array_equal(getattr(loaded, name), getattr(model, name))
    assert loaded.indices == (2, 2) and loaded.info == {"wc": 0.3}
    assert loaded.output_names == model.output_names


def test_load_rejects_bad_files(tmp_path):
    with pytest.raises(moli.ModelFileError, match="no model file"):
        moli.load_model(tmp_path / "missing.json")
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(moli.ModelFileError, match="not a JSON"):
        moli.load_model(tmp_path / "junk.json")
    content = random_system(2, 1, 1, np.random.default_rng(3)).to_dict()
    content["version"] = "99.0"
    (tmp_path / "future.json").write_text(json.dumps(content))
    with pytest.raises(moli.ModelFileError, match="cannot read"):
        moli.load_model(tmp_path / "future.json")
    content["version"] = moli.__version__
    content["B"] = [[1.0, 2.0, 3.0]]
    (tmp_path / "shape.json").write_text(json.dumps(content))
    with pytest.raises(moli.ModelFileError, match="inconsistent"):
        moli.load_model(tmp_path / "shape.json")


def test_to_control_keeps_matrices_and_names():
    control = pytest.importorskip("control")
    model = random_system(3, 2, 1, np.random.default_rng(4))
    sys = model.to_control()
    assert isinstance(sys, control.StateSpace)
    np.testing.assert_array_equal(sys.A, model.A)
    assert sys.dt == 1.0
    assert list(sys.output_labels) == ["y1", "y2"] and list(sys.input_labels) == ["u1"]
    # python-control's own simulation agrees with ours
    u = np.random.default_rng(5).standard_normal(50)
    response = control.forced_response(sys, T=np.arange(50.0), U=u)
    np.testing.assert_allclose(response.outputs.T, model.simulate(u), atol=1e-10)


def test_simulate_checks_input_shape():
    model = random_system(2, 1, 2, np.random.default_rng(6))
    with pytest.raises(moli.DataError, match=r"\(N, 2\)"):
        model.simulate(np.zeros(10))
    with pytest.raises(moli.DataError, match="x0"):
        model.simulate(np.zeros((10, 2)), x0=[1.0])


def test_metrics_known_values():
    y = np.array([0.0, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(moli.vaf(y, y), [100.0])
    np.testing.assert_allclose(moli.vaf(y, y + 1.0), [100.0])  # an offset is not variance
    np.testing.assert_allclose(moli.vaf(y, -y), [0.0])  # var(2y)/var(y) = 4: clipped
    np.testing.assert_allclose(moli.vaf(y, 0.5 * y), [75.0])  # 1 - 0.25
    assert moli.cost_j(np.column_stack([y, y]), np.column_stack([0.5 * y, -y])) == pytest.approx(0.625)
    # ||y - yhat|| / ||y - mean|| = 0.5 for yhat = mean + (y - mean)/2
    np.testing.assert_allclose(moli.nrmse_fit(y, 0.75 + 0.5 * y), [50.0])
    assert np.isinf(moli.nrmse_fit(y, np.full(4, np.inf))).all()


def test_compare_with_estimated_initial_state():
    rng = np.random.default_rng(7)
    model = random_system(3, 2, 1, rng)
    u = rng.standard_normal(80)
    x0 = rng.standard_normal(3)
    data = moli.IOData(model.simulate(u, x0), u)
    assert moli.compare(model, data, x0="estimate").mean_vaf == pytest.approx(100.0, abs=1e-8)
    np.testing.assert_allclose(moli.compare(model, data, x0="estimate").x0, x0, atol=1e-8)
    assert moli.compare(model, data).mean_vaf < 100.0
    with pytest.raises(moli.OptionError, match="x0"):
        moli.compare(model, data, x0="guess")
