"""BLAS limited to one thread inside moli's computations, the caller's setting restored after."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import moli
from moli.numerics.blas_threads import ENVIRONMENT_VARIABLE, blas_thread_limit
from tests.cli_util import assert_clean_error, run

# the short example record's set-point-like input makes the feedback check say it cannot tell
pytestmark = pytest.mark.filterwarnings("ignore::moli.ClosedLoopWarning")


def blas_threads() -> set[int]:
    """The thread counts the loaded BLAS libraries report now (numpy's and scipy's)."""
    return {library["num_threads"] for library in threadpool_info() if library["user_api"] == "blas"}


@pytest.fixture
def two_threads():
    """The caller runs BLAS with 2 threads: what it gets back after each moli call."""
    if not blas_threads():
        pytest.skip("threadpoolctl finds no BLAS library to limit in this environment")
    with threadpool_limits(2, user_api="blas"):
        yield blas_threads()


@pytest.fixture
def record():
    return moli.example_data(N=400, seed=3).split(250)


def threads_seen_by_identify(record) -> list[set[int]]:
    seen: list[set[int]] = []
    moli.identify(*record, nmax=4, preset="fast", progress=lambda step: seen.append(blas_threads()))
    return seen


def test_identify_runs_on_one_blas_thread_and_gives_the_callers_back(two_threads, record):
    seen = threads_seen_by_identify(record)
    assert seen and all(threads == {1} for threads in seen)
    assert blas_threads() == two_threads


def test_the_environment_sets_another_limit_or_keeps_the_callers(two_threads, record, monkeypatch):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "2")
    assert all(threads == {2} for threads in threads_seen_by_identify(record))
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "keep")
    assert all(threads == two_threads for threads in threads_seen_by_identify(record))
    assert blas_threads() == two_threads


@pytest.mark.parametrize("value", ["0", "-1", "1.5", "abc", "", "²"])
def test_a_bad_setting_is_refused_before_any_work(value, record, monkeypatch):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, value)
    calls = []
    with pytest.raises(moli.OptionError, match=ENVIRONMENT_VARIABLE):
        moli.identify(*record, nmax=4, progress=calls.append)
    assert calls == []          # not one order of the path ran


def test_unset_means_one_thread(monkeypatch):
    monkeypatch.delenv(ENVIRONMENT_VARIABLE, raising=False)
    assert blas_thread_limit() == 1


def test_nested_and_concurrent_calls_restore_the_callers_threads(two_threads, record):
    model = moli.identify(*record, nmax=4, preset="fast").model
    inner: list[set[int]] = []

    def nested(step):            # a moli call inside another: the outer call's limit holds, and stays
        moli.compare(model, record[1])
        inner.append(blas_threads())

    moli.identify(*record, nmax=4, preset="fast", progress=nested)
    assert inner and all(threads == {1} for threads in inner)
    errors: list[BaseException] = []

    def work():
        try:
            moli.impulse_response(record[0], length=20)
        except BaseException as exc:  # noqa: BLE001 (reported by the assertion below)
            errors.append(exc)

    workers = [threading.Thread(target=work) for _ in range(3)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    assert errors == []
    assert blas_threads() == two_threads


def test_the_same_model_whatever_the_callers_threads(record):
    # one BLAS thread inside identify whatever the caller set: the same arithmetic, the same bits
    with threadpool_limits(1, user_api="blas"):
        one = moli.identify(*record, nmax=4, preset="fast").model
    with threadpool_limits(2, user_api="blas"):
        two = moli.identify(*record, nmax=4, preset="fast").model
    for a, b in zip((one.A, one.B, one.C, one.D), (two.A, two.B, two.C, two.D)):
        np.testing.assert_array_equal(a, b)


def test_the_command_line_refuses_a_bad_setting_in_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "many")
    assert_clean_error(run("demo", "--out", str(tmp_path / "demo")), ENVIRONMENT_VARIABLE)
