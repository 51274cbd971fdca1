import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from moli.method.structure.filters import _schur_stable, filter_divisors, filter_roots, filter_rows

indices_lists = st.lists(st.integers(1, 7), min_size=1, max_size=4)


# wc from 0.05 rad/sample (1.6 % of Nyquist) up: slower filters put up to 7 roots within
# 0.01 of each other near z = 1, where the coefficient form itself is ill-conditioned
# (np.roots then misplaces roots by ~1e-3); identify builds those from roots directly.
@settings(max_examples=300, deadline=None)
@given(
    indices=indices_lists,
    wc=st.floats(0.05, 2.5),
    zeta=st.floats(0.3, 3.0),
    s=st.floats(1.2, 4.0),
)
def test_every_list_gets_valid_divisors(indices, wc, zeta, s):
    alpha = moli.filter_polynomial(wc, zeta, indices, s=s)
    assert alpha[0] == 1.0 and alpha.size == max(indices) + 1
    assert np.max(np.abs(np.roots(alpha))) < 1.0
    for l, alpha_j in zip(indices, moli.divisors(alpha, tuple(indices))):
        assert alpha_j.size == l + 1 and alpha_j[0] == 1.0
        # alpha_j divides alpha up to the accuracy of roots recovered from coefficients:
        # repeated roots (zeta = 1, clustered slow roots) come back from np.roots only to
        # ~sqrt(eps) amplified by the cluster, which left remainders up to 6e-6
        _, remainder = np.polydiv(alpha, alpha_j)
        assert np.max(np.abs(remainder)) < 1e-4


def test_dominant_pair_and_powers():
    wc, zeta = 0.5, 0.6
    roots = filter_roots(wc, zeta, [4])
    z1 = np.exp(wc * (-zeta + 1j * np.sqrt(1 - zeta**2)))
    np.testing.assert_allclose(sorted(roots, key=np.angle), sorted([z1, np.conj(z1), z1**2, np.conj(z1) ** 2], key=np.angle))


def test_odd_index_below_even_nbar_gets_real_roots():
    roots = filter_roots(0.5, 0.6, [1, 2])
    assert np.allclose(roots.imag, 0.0)
    # the replaced pair keeps its modulus
    np.testing.assert_allclose(np.abs(roots), np.exp(-0.5 * 0.6))


def test_single_index_is_real_root():
    np.testing.assert_allclose(moli.filter_polynomial(0.5, 1.0, [1]), [1.0, -np.exp(-0.5)])


def test_divisor_picks_slowest_roots():
    alpha = np.poly([0.9, 0.5, 0.2])
    np.testing.assert_allclose(moli.divisor(alpha, 2), np.poly([0.9, 0.5]))


@pytest.mark.parametrize(
    "alpha, message",
    [
        ([2.0, 0.5], "monic"),
        ([1.0, -1.2], "stable"),
        ([1.0, np.nan], "finite"),
        ([1.0], "degree"),
    ],
)
def test_bad_alpha(alpha, message):
    with pytest.raises(moli.FilterError, match=message):
        moli.divisor(alpha, 1)


def test_odd_divisor_without_real_root():
    pair = np.real(np.poly([0.5 + 0.3j, 0.5 - 0.3j]))
    with pytest.raises(moli.FilterError, match="no real root"):
        moli.divisor(pair, 1)
    with pytest.raises(moli.FilterError, match="no real root"):
        moli.divisors(pair, (1, 2))


def test_bad_filter_parameters():
    with pytest.raises(moli.FilterError):
        moli.filter_polynomial(-1.0, 0.7, [2])
    with pytest.raises(moli.FilterError):
        moli.filter_polynomial(1.0, 0.7, [2], s=1.0)


# filter_rows builds a whole candidate batch with vector arithmetic; it must follow the
# one-row root rule exactly, including zeta = 1 (a double root), zetas just below 1
# (pairs the rule may read as real roots: those rows take the one-row route) and slow
# filters whose fast roots underflow. Coefficients are sums of up to C(7, 3) = 35
# products of numbers below 1, so 1e-12 is a few hundred ulps of the largest.
@settings(max_examples=200, deadline=None)
@given(
    indices=indices_lists,
    wcs=st.lists(st.floats(1e-3, 3.0), min_size=1, max_size=6),
    zetas=st.lists(st.sampled_from([0.3, 0.6, 0.7, 1.0 - 1e-13, 1.0, 1.1, 2.5]), min_size=6, max_size=6),
    Ts=st.sampled_from([0.1, 1.0, 10.0]),
    s=st.floats(1.2, 4.0),
)
def test_filter_rows_match_the_one_row_rule(indices, wcs, zetas, Ts, s):
    etas = np.column_stack([wcs, zetas[: len(wcs)]])
    alphas, divisors = filter_rows(etas, tuple(indices), Ts, s)
    for r, (wc, zeta) in enumerate(etas):
        np.testing.assert_allclose(alphas[r], moli.filter_polynomial(wc, zeta, indices, Ts, s), rtol=0, atol=1e-12)
        for l, alpha_j in zip(indices, filter_divisors(wc, zeta, tuple(indices), Ts, s)):
            np.testing.assert_allclose(divisors[l][r], alpha_j, rtol=0, atol=1e-12)


def test_filter_rows_rejects_bad_candidates():
    with pytest.raises(moli.FilterError, match="positive"):
        filter_rows(np.array([[0.5, 0.7], [-1.0, 0.7]]), (2, 1))
    with pytest.raises(moli.FilterError, match="spacing"):
        filter_rows(np.array([[0.5, 0.7]]), (2, 1), s=1.0)


@settings(max_examples=200, deadline=None)
@given(
    moduli=st.lists(st.floats(0.05, 1.5), min_size=1, max_size=6),
    angles=st.lists(st.floats(0.0, np.pi), min_size=6, max_size=6),
)
def test_stability_test_agrees_with_the_roots(moduli, angles):
    # conjugate pairs for the first half of the moduli, real roots (either sign) after
    half = len(moduli) // 2
    pairs = [m * np.exp(1j * a) for m, a in zip(moduli[:half], angles)]
    reals = [m * np.sign(np.cos(a)) or m for m, a in zip(moduli[half:], angles[half:])]
    coeffs = np.real(np.poly(np.concatenate([pairs, np.conj(pairs), reals])))
    radius = np.max(np.abs(np.roots(coeffs)))
    built = max(moduli)  # the radius the roots were built with
    # On the circle, round-off may decide either way; and clustered roots near it are
    # moved by the coefficients' rounding (by about eps**(1/multiplicity)), so the
    # stored polynomial is only judged where the built and the computed radius agree.
    if abs(radius - 1.0) > 1e-9 and (built < 1.0) == (radius < 1.0):
        # it never certifies an unstable polynomial; a stable one it does not certify is
        # left to the roots (check_alpha), which happens only near the circle, where the
        # recursion's round-off grows like 1 / (1 - |k|^2) (roots at 0.99999 seen)
        certified = _schur_stable(coeffs)
        assert not (certified and radius >= 1.0)
        if radius < 1.0 - 1e-3:
            assert certified
