import numpy as np
import pytest

import moli


def test_copies_inputs_and_is_read_only():
    y = np.arange(10.0)
    u = np.ones((10, 2))
    data = moli.IOData(y, u)
    y[0] = 99.0
    assert data.y[0, 0] == 0.0
    with pytest.raises(ValueError):
        data.y[0, 0] = 1.0


def test_shapes_names_and_repr():
    data = moli.IOData(np.zeros((5, 2)), np.zeros(5), Ts=0.1, output_names=["a", "b"])
    assert (data.N, data.p, data.m) == (5, 2, 1)
    assert repr(data) == "IOData(N=5, p=2, m=1, Ts=0.1, outputs=['a', 'b'], inputs=['u1'])"


@pytest.mark.parametrize(
    "y, u, message",
    [
        (np.zeros(5), np.zeros(6), "same number of samples"),
        (np.array([0.0, np.inf, 1.0]), np.zeros(3), "contains inf"),
        (np.zeros(3), np.array([0.0, -np.inf, 1.0]), "contains inf"),
        (np.full(3, np.nan), np.zeros(3), "every one of the 3 samples"),
        (np.zeros((2, 2, 2)), np.zeros(2), "1-D"),
        (["a", "b"], np.zeros(2), "numeric"),
    ],
)
def test_bad_arrays_raise_clear_errors(y, u, message):
    with pytest.raises(moli.DataError, match=message):
        moli.IOData(y, u)


def test_bad_ts_and_names():
    with pytest.raises(moli.DataError, match="Ts"):
        moli.IOData(np.zeros(3), np.zeros(3), Ts=0)
    with pytest.raises(moli.DataError, match="names"):
        moli.IOData(np.zeros(3), np.zeros(3), output_names=["a", "b"])


def test_split_and_slice():
    data = moli.IOData(np.arange(10.0), np.arange(10.0))
    head, tail = data.split(0.7)
    assert (head.N, tail.N) == (7, 3)
    assert tail.y[0, 0] == 7.0
    assert data[2:4].N == 2
    with pytest.raises(moli.DataError):
        data.split(10)


def test_remove_means_remembers_offsets():
    rng = np.random.default_rng(0)
    y = rng.standard_normal((50, 2)) + [3.0, -1.0]
    u = rng.standard_normal((50, 1)) + 5.0
    data = moli.IOData(y, u)
    centred = data.remove_means()
    np.testing.assert_allclose(centred.y.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(centred.y + centred.y_offset, y, atol=1e-12)
    # applying another record's offsets: the second record keeps its own mean shift
    other = moli.IOData(y + 1.0, u).remove_means(centred.y_offset, centred.u_offset)
    np.testing.assert_allclose(other.y.mean(axis=0), 1.0, atol=1e-12)
    np.testing.assert_allclose(other.y_offset, centred.y_offset)
