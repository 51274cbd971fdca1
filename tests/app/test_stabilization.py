"""The stabilization diagram's marks on models whose modes are set by hand, and on a fit's orders."""

from __future__ import annotations

import numpy as np

import moli
from moli.app.stabilization import mac, stabilization, stabilization_figure


def modal_model(natural: list[float], damping: list[float], shapes: list[list[float]]) -> moli.ContinuousModel:
    """A continuous model whose modes are exactly the given ones: each a block [[sigma, omega], [-omega, sigma]]
    (eigenvector [1, j]), its output shape the block's first column of C."""
    n, p = 2 * len(natural), len(shapes[0])
    A, C = np.zeros((n, n)), np.zeros((p, n))
    for k, (wn, zeta, shape) in enumerate(zip(natural, damping, shapes)):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        A[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[sigma, omega], [-omega, sigma]]
        C[:, 2 * k] = shape
    return moli.ContinuousModel(A, np.ones((n, 1)), C, np.zeros((p, 1)), tuple(f"y{i}" for i in range(p)), ("u",),
                                np.zeros(p), np.zeros(1), (0.0,))


def test_each_mark_follows_the_tolerances():
    shape, other = [1.0, 0.5], [1.0, -0.5]       # MAC |1 - 0.25|^2 / 1.25^2 = 0.36
    models = [
        modal_model([10.0], [0.02], [shape]),
        # 0.5 % and 2.5 % off, the same shape: all three; 30 rad/s is new
        modal_model([10.05, 30.0], [0.0205, 0.01], [shape, shape]),
        # 10.25: 2 % off 10.05, new; 30.09: 0.3 % off, damping 20 % off, shape kept: frequency and shape;
        # 60: new
        modal_model([10.25, 30.09, 60.0], [0.0205, 0.012, 0.01], [shape, shape, shape]),
        # 10.26 (0.1 %), damping 1 % off, the other shape: frequency and damping; 30.1 (0.03 %), damping 50 %
        # off, the other shape: frequency alone; 60 unchanged: all three; 90 new
        modal_model([10.26, 30.1, 60.0, 90.0], [0.0207, 0.018, 0.01, 0.01], [other, other, shape, shape]),
    ]
    marks = [(pt.order, round(pt.mode.natural_frequency, 6), pt.status) for pt in stabilization(models)]
    assert marks == [(2, 10.0, "new"),
                     (4, 10.05, "all"), (4, 30.0, "new"),
                     (6, 10.25, "new"), (6, 30.09, "shape"), (6, 60.0, "new"),
                     (8, 10.26, "damping"), (8, 30.1, "frequency"), (8, 60.0, "all"), (8, 90.0, "new")]


def test_mac_of_shapes_computed_by_hand():
    assert abs(mac(np.array([1.0, 0.5]), np.array([1.0, -0.5])) - 0.5625 / 1.5625) < 1e-15     # |0.75|^2 / 1.25^2
    assert abs(mac(np.array([1.0, 1j]), np.array([2j, -2.0])) - 1.0) < 1e-15       # the same shape times 2j
    assert mac(np.zeros(2), np.array([1.0, 0.0])) == 0.0


def test_the_true_modes_stay_stable_over_a_fit_s_orders(tmp_path):
    wn, zeta = [10.0, 23.0], [0.01, 0.02]
    truth = modal_model(wn, zeta, [[1.0, 0.3], [0.4, 1.0]])
    omega = np.logspace(0, 2, 600)
    data = moli.FrequencyData(omega, truth.frequency_response(omega), unit="rad/s")
    result = moli.identify(data, nmax=7)
    assert [model.n for model in result.path_models] == [step.order for step in result.path]
    points = stabilization(result.path_models)
    for order in range(5, 8):       # from the order after the true one (4), each true mode is confirmed
        for target in wn:
            near = [pt for pt in points if pt.order == order and abs(pt.mode.natural_frequency - target) < 1e-3 * target]
            assert [pt.status for pt in near] == ["all"], (order, target)
    fig = stabilization_figure(points, result.selected.order, (omega[0] / (2 * np.pi), omega[-1] / (2 * np.pi)))
    assert fig.axes[0].get_ylabel() == "order (states)"


def test_an_order_whose_model_has_a_pole_at_zero_shows_no_modes_and_the_next_starts_anew():
    # a sampled model with a pole at z = 0 (a pure delay) has no continuous-time modes: the
    # diagram leaves that order empty instead of failing, and the next order's modes are all new
    delay = moli.StateSpaceModel(np.diag([0.0, 0.9]), [[1.0], [1.0]], [[1.0, 1.0]], Ts=0.1)
    plain = moli.StateSpaceModel([[0.9]], [[1.0]], [[1.0]], Ts=0.1)
    points = stabilization([plain, delay, plain])
    assert [pt.order for pt in points] == [1, 1]
    assert points[-1].status == "new"
