"""A fleet of loop records, and one very long record, on local processes and Dask.

1. ``RECORDS`` records of a typical loop test (2x2, ``SAMPLES`` samples, a seeded random
   4-state plant each) identified serially, on 2 local processes (moli's own workers) and on a
   2-worker Dask LocalCluster; the models must be the same bit for bit.
2. A ``LONG``-sample 2x2 record (order 4) reduced over chunks of ``CHUNK`` samples generated on
   the Dask workers (moli.fleets.chunk_reduction.estimate_chunks), against one
   ChunkedEstimator fed the same chunks in this process.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/fleet.py [records] [samples] [long] [chunk]
"""

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

import cloudpickle

import fleet_cases
import moli
from fleet_cases import ALPHA, DENOMINATORS, INDICES, generated_chunk, loop_record
from moli.fleets.chunk_reduction import estimate_chunks
from moli.streaming.chunked import ChunkedEstimator

# the chunks are made on the workers, which need not find this folder on their path
cloudpickle.register_pickle_by_value(fleet_cases)

RECORDS = int(sys.argv[1]) if len(sys.argv) > 1 else 200
SAMPLES = int(sys.argv[2]) if len(sys.argv) > 2 else 2_000
LONG = int(float(sys.argv[3])) if len(sys.argv) > 3 else 10**8
CHUNK = int(float(sys.argv[4])) if len(sys.argv) > 4 else 10**6


def load() -> str:
    return Path("/proc/loadavg").read_text().split()[0] if Path("/proc/loadavg").exists() else "?"


def spin(_: int = 0) -> float:
    start = time.perf_counter()
    total = 0
    for i in range(5_000_000):
        total += i
    return time.perf_counter() - start


def free_cores() -> float:
    """How many cores two busy processes get now: 2 on an idle 2-core machine."""
    from concurrent.futures import ProcessPoolExecutor

    alone = spin()
    with ProcessPoolExecutor(2) as pool:
        pool.submit(spin).result()  # start both workers before timing
        together = max(pool.map(spin, range(2)))
    return 2 * alone / together


def same(first: moli.FleetResult, second: moli.FleetResult) -> bool:
    return all(a.error == b.error and (a.result is None or all(
        np.array_equal(getattr(a.result.model, n), getattr(b.result.model, n)) for n in "ABCD"))
        for a, b in zip(first, second))


def timed(call):
    start = time.perf_counter()
    value = call()
    return value, time.perf_counter() - start


def cluster(trim: bool = False):
    """A 2-worker LocalCluster and its client, started only for the runs that use it.

    Dask's nannies start their workers with MALLOC_TRIM_THRESHOLD_=65536, which makes
    glibc map and unmap every medium-sized array: an identification then takes 1.5 to
    2 times longer. Unless ``trim``, the workers start without it (docs/fleet.md).
    """
    import dask
    from distributed import Client, LocalCluster

    started = time.perf_counter()
    unset = {} if trim else {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
    with dask.config.set(unset):
        local = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(local)
    print(f"LocalCluster start: {time.perf_counter() - started:.1f} s (load {load()})")
    return local, client


def fleet_part() -> None:
    records = [loop_record(seed, SAMPLES) for seed in range(RECORDS)]
    options = moli.IdentifyOptions()
    moli.identify(records[0], options=options)  # imports, so that serial pays none of them
    print(f"## {RECORDS} records, 2x2, {SAMPLES} samples, default options "
          f"(load {load()}, free cores {free_cores():.2f})")

    def serial():
        return moli.identify_many(records, options, n_jobs=1, progress=False)

    def local():
        return moli.identify_many(records, options, n_jobs=2, progress=False)

    reference, t_serial = timed(serial)
    print(f"{'serial:':38s} {t_serial:6.1f} s  (load {load()})", flush=True)
    # the background load of this shared machine varies: serial and parallel runs
    # alternate, and each figure is the best of its runs
    times: dict[str, list[float]] = {"serial": [t_serial]}
    for label, run in [("2 local processes, cold", local), ("serial", serial),
                       ("2 local processes, warm", local), ("serial", serial),
                       ("2 local processes, warm", local)]:
        result, seconds = timed(run)
        times.setdefault(label, []).append(seconds)
        print(f"{label + ':':38s} {seconds:6.1f} s  identical: {same(reference, result)}  (load {load()})", flush=True)
    for trim, name, warm_runs in [(True, "LocalCluster, Dask's malloc trim", 1), (False, "LocalCluster", 2)]:
        local_cluster, client = cluster(trim)
        with local_cluster, client:
            for label in [f"{name}, cold"] + [f"{name}, warm"] * warm_runs:
                result, seconds = timed(lambda: moli.identify_many(records, options, executor=client, progress=False))
                times.setdefault(label, []).append(seconds)
                print(f"{label + ':':38s} {seconds:6.1f} s  identical: {same(reference, result)}  (load {load()})",
                      flush=True)
    best_serial = min(times.pop("serial"))
    print(f"\nbest serial: {best_serial:.1f} s ({1e3 * best_serial / RECORDS:.0f} ms per record)")
    for label, runs in times.items():
        best = min(runs)
        # overhead: the time two workers spend beyond half the serial time, per record
        print(f"{label + ':':38s} best {best:5.1f} s  speed-up {best_serial / best:4.2f}  "
              f"overhead {1e3 * (2 * best - best_serial) / RECORDS:5.1f} ms per record")
    print(f"failures: {len(reference.failures)}; mean order "
          f"{np.mean([e.result.selected.order for e in reference]):.2f}; free cores now: {free_cores():.2f}")


def long_part() -> None:
    count = -(-LONG // CHUNK)
    lengths = [min(CHUNK, LONG - k * CHUNK) for k in range(count)]
    chunks = [partial(generated_chunk, k, length) for k, length in enumerate(lengths)]
    print(f"\n## long record: {LONG:.3g} samples, 2x2, {count} chunks of {CHUNK:.3g} generated on the workers "
          f"(load {load()})")
    local_cluster, client = cluster()
    reduced, t_dask = timed(lambda: estimate_chunks(chunks, INDICES, ALPHA, 2, client=client))
    print(f"LocalCluster, 2 workers:  {t_dask:6.1f} s  ({LONG / t_dask:.3g} samples/s)  (load {load()})", flush=True)
    once, t_once = timed(lambda: estimate_chunks(chunks, INDICES, ALPHA, 2, client=client, read_once=True))
    print(f"  the same, read_once:    {t_once:6.1f} s  ({LONG / t_once:.3g} samples/s)  (load {load()})", flush=True)
    client.close()
    local_cluster.close()

    def single() -> ChunkedEstimator:
        est = ChunkedEstimator(INDICES, ALPHA, 2)
        for chunk in chunks:
            est.add(*chunk())
        return est

    reference, t_single = timed(single)
    print(f"one process, in turn:     {t_single:6.1f} s  ({LONG / t_single:.3g} samples/s)  "
          f"speed-up {t_single / t_dask:.2f}, read_once {t_single / t_once:.2f}  (load {load()})")
    expected = reference.model()
    for label, estimator in (("", reduced), (", read_once", once)):
        model = estimator.model()
        gap = max(np.max(np.abs(getattr(model, n) - getattr(expected, n))) / np.max(np.abs(getattr(expected, n)))
                  for n in "ABC")
        print(f"largest relative difference of A, B, C{label}: {gap:.2e}; samples {estimator.samples}")
    print(f"free cores now: {free_cores():.2f}")
    plant_poles = np.concatenate([np.roots(a) for a in DENOMINATORS])
    print(f"pole moduli: model {np.sort(np.abs(model.poles())).round(4)}, plant {np.sort(np.abs(plant_poles)).round(4)}")


if __name__ == "__main__":
    print(f"machine: 2 cores; load {load()}; free cores (two busy loops' share of the CPU): {free_cores():.2f}")
    if RECORDS:
        fleet_part()
    if LONG:
        long_part()
