"""BLAS limited to one thread inside moli's computations, the caller's setting restored after."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest
import threadpoolctl
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


@pytest.mark.parametrize("value", ["0", "-1", "1.5", "abc", "", "²", "1025", "2147483648", "99999999999999999999"])
def test_a_bad_setting_is_refused_before_any_work(value, record, monkeypatch):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, value)
    calls = []
    with pytest.raises(moli.OptionError, match=ENVIRONMENT_VARIABLE):
        moli.identify(*record, nmax=4, progress=calls.append)
    assert calls == []          # not one order of the path ran


def test_unset_means_one_thread(monkeypatch):
    monkeypatch.delenv(ENVIRONMENT_VARIABLE, raising=False)
    assert blas_thread_limit() == 1
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, " KEEP ")
    assert blas_thread_limit() is None


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
    # one BLAS thread inside identify whatever the caller set (what can fail here: on this small
    # record even unlimited BLAS gives the same bits), so the same path runs twice, to the bit
    seen: dict[int, list[set[int]]] = {1: [], 2: []}
    models = {}
    for caller in (1, 2):
        with threadpool_limits(caller, user_api="blas"):
            models[caller] = moli.identify(*record, nmax=4, preset="fast",
                                           progress=lambda step, c=caller: seen[c].append(blas_threads())).model
    assert all(seen[c] and all(threads == {1} for threads in seen[c]) for c in (1, 2))
    one, two = models[1], models[2]
    for a, b in zip((one.A, one.B, one.C, one.D), (two.A, two.B, two.C, two.D)):
        np.testing.assert_array_equal(a, b)


def test_the_command_line_refuses_a_bad_setting_in_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "many")
    assert_clean_error(run("demo", "--out", str(tmp_path / "demo")), ENVIRONMENT_VARIABLE)


def in_thread(work):
    """Run ``work`` on a new thread and return what it returned (re-raising what it raised)."""
    out: list = []

    def target():
        try:
            out.append(("ok", work()))
        except BaseException as exc:  # noqa: BLE001 (re-raised below, in the test's thread)
            out.append(("error", exc))

    worker = threading.Thread(target=target)
    worker.start()
    worker.join()
    kind, value = out[0]
    if kind == "error":
        raise value
    return value


def test_a_call_on_another_thread_after_one_on_this_thread_is_limited_too(record):
    # threadpoolctl (3.8 on) lets one thread own OpenBLAS's shared pool: a moli call must not keep it
    if not blas_threads():
        pytest.skip("threadpoolctl finds no BLAS library to limit in this environment")
    caller = threadpool_limits(2, user_api="blas")      # this thread sets the pool, and owns it
    try:
        threads_seen_by_identify(record)
        seen = in_thread(lambda: threads_seen_by_identify(record))
        assert seen and all(threads == {1} for threads in seen)
        # the caller's own limits, on yet another thread, still take
        assert in_thread(lambda: _limited_elsewhere(3)) == {3}
    finally:
        release = getattr(getattr(threadpoolctl, "OpenBLASController", None), "clear_controlling_thread", None)
        if release is not None:
            release(force=True)
        caller.restore_original_limits()


def _limited_elsewhere(n: int) -> set[int]:
    with threadpool_limits(n, user_api="blas"):
        return blas_threads()


def test_overlapping_calls_on_two_threads_give_the_callers_threads_back(two_threads, record):
    first_in = threading.Event()
    second_done = threading.Event()
    seen: list[set[int]] = []

    def first():                 # enters first, leaves first, and its thread lives on after the call
        def hold(step):
            first_in.set()
            seen.append(blas_threads())
        moli.identify(*record, nmax=4, preset="fast", progress=hold)
        second_done.wait(60)

    def second():                # enters while the first call runs, leaves last
        first_in.wait(60)
        moli.identify(*record, nmax=4, preset="fast", progress=lambda step: seen.append(blas_threads()))
        second_done.set()

    workers = [threading.Thread(target=first), threading.Thread(target=second)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    assert seen and all(threads == {1} for threads in seen)
    assert blas_threads() == two_threads


@pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork is POSIX only")
def test_a_child_forked_while_a_call_holds_the_lock_still_runs(record):
    # the lock held by another thread at the fork would otherwise never be released in the child
    import moli.numerics.blas_threads as blas

    with blas._lock:
        pid = os.fork()
        if pid == 0:             # the child: one moli call, then out without pytest's cleanup
            try:
                moli.compare(moli.identify(*record, nmax=4, preset="fast").model, record[1])
                os._exit(0)
            except BaseException:  # noqa: BLE001 (the exit code says it failed)
                os._exit(1)
    # a child stuck on the lock is killed after 60 s (the call itself takes well under one)
    deadline = time.monotonic() + 60.0
    while (done := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    if done[0] == 0:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung on moli's BLAS lock")
    assert os.waitstatus_to_exitcode(done[1]) == 0


def test_identify_many_refuses_a_bad_setting_before_any_record(record, monkeypatch):
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, "none")
    with pytest.raises(moli.OptionError, match=ENVIRONMENT_VARIABLE):
        moli.identify_many({"a": record[0]}, n_jobs=2, progress=False)
