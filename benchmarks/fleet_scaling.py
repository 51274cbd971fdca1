"""How a fleet and a chunked reduction scale with workers: one process, loky, Dask.

Every parallel run is given the same work per worker (``--records-per-worker`` loop
records, ``--chunks-per-worker`` chunks), so each lasts about as long whatever the
number of workers and the tail of the last tasks weighs the same in each. Per worker
count it times:

- the fleet on loky's processes and on a Dask LocalCluster started under
  ``moli.fleets.dask_worker_config()`` (best of ``--repeats`` runs after a warm-up); with
  ``--before``, also the largest cluster with Dask's defaults (``MALLOC_TRIM_THRESHOLD_``
  unset only) and moli's pause of the workers' profiler turned off, as fleets ran
  before (the records are submitted as now, in one ``client.map``);
- where each record's time went on its worker: CPU, waiting for a CPU, blocked; and the
  CPU of the workers' other threads and of the calling process (Linux's schedstat);
- each record's time on its worker (``FleetEntry.seconds``) against its time in one process;
- ``estimate_chunks`` on the same cluster, reading each chunk twice and with ``read_once``.

Speed-ups are against one process: records per second of ``identify_many(n_jobs=1)`` on
``--serial-records`` records, samples per second of one ``ChunkedEstimator`` fed
``--serial-chunks`` chunks. Every fleet's models must equal the serial ones bit for bit
(on the records both ran) and each other's; every reduction must equal the one-process
estimate of the same chunks to round-off.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/fleet_scaling.py --workers 2,8,16 --out DIR
Prints a markdown table; writes DIR/fleet_scaling.json.
"""

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import contextlib
import json
import os
import platform
import sys
import time
from functools import partial
from pathlib import Path

import cloudpickle
import numpy as np

import fleet_cases
import moli
from fleet_cases import ALPHA, INDICES, generated_chunk, loop_record
from moli.fleets import backends
from moli.fleets.backends import usable_cpus
from moli.fleets.chunk_reduction import estimate_chunks
from moli.streaming.chunked import ChunkedEstimator

# the records and chunks are made from this module on the workers, which need not find it
cloudpickle.register_pickle_by_value(fleet_cases)


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="2,8,16", help="worker counts, comma-separated")
    parser.add_argument("--records-per-worker", type=int, default=16)
    parser.add_argument("--serial-records", type=int, default=32)
    parser.add_argument("--samples", type=int, default=2000, help="samples per loop record")
    parser.add_argument("--chunk", type=float, default=1e6, help="samples per chunk")
    parser.add_argument("--chunks-per-worker", type=int, default=4)
    parser.add_argument("--serial-chunks", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=2, help="timed runs per case; the best is kept")
    parser.add_argument("--before", action="store_true", help="also the largest cluster as fleets ran before")
    parser.add_argument("--out", type=Path, required=True, help="folder for fleet_scaling.json")
    return parser.parse_args()


def load() -> float:
    return os.getloadavg()[0]


def say(text: str) -> None:
    print(f"{text}  (load {load():.2f})", flush=True)


def models(fleet: moli.FleetResult) -> list:
    return [None if e.result is None else [getattr(e.result.model, n) for n in "ABCD"] for e in fleet]


def identical(a: list, b: list) -> bool:
    """The models of the records both lists hold, bit for bit."""
    return all((x is None) == (y is None) and (x is None or all(np.array_equal(p, q) for p, q in zip(x, y)))
               for x, y in zip(a, b))


def best_of(repeats: int, run) -> tuple[object, float]:
    value, times = None, []
    for _ in range(repeats):
        start = time.perf_counter()
        value = run()
        times.append(time.perf_counter() - start)
    return value, min(times)


def thread_clocks() -> dict[tuple[int, str], tuple[float, float]]:
    """Per thread of this process and its children: (CPU s, s runnable but waiting for a CPU)."""
    import psutil

    clocks = {}
    for pid in [os.getpid()] + [child.pid for child in psutil.Process().children(recursive=True)]:
        with contextlib.suppress(OSError):
            for tid in os.listdir(f"/proc/{pid}/task"):
                with contextlib.suppress(OSError), open(f"/proc/{pid}/task/{tid}/schedstat") as stat:
                    cpu, wait = (int(v) / 1e9 for v in stat.read().split()[:2])
                    clocks[pid, tid] = cpu, wait
    return clocks


def timed_fleet(repeats: int, run) -> tuple[moli.FleetResult, float, dict]:
    """The best of ``repeats`` runs, and where its records' time went (Linux's schedstat).

    In each process the thread that ran the records is the one that used the most CPU;
    a record's time beyond that thread's CPU and its wait for a CPU is time it was
    blocked: on the interpreter lock, as an identification does no I/O.
    """
    best: tuple = (None, float("inf"), {})
    for _ in range(repeats):
        before, here = thread_clocks(), time.process_time()
        start = time.perf_counter()
        fleet = run()
        wall = time.perf_counter() - start
        after, here = thread_clocks(), time.process_time() - here
        spent: dict[int, list] = {}
        for key, (cpu, wait) in after.items():
            cpu0, wait0 = before.get(key, (0.0, 0.0))
            spent.setdefault(key[0], []).append((cpu - cpu0, wait - wait0))
        tasks = [max(threads) for pid, threads in spent.items() if pid != os.getpid() or len(spent) == 1]
        n = len(fleet)
        cpu, wait = (sum(t[i] for t in tasks) / n for i in (0, 1))
        others = sum(c for pid, threads in spent.items() if pid != os.getpid() for c, _ in threads) / n - cpu
        clocks = {"cpu_per_record_s": cpu, "cpu_wait_per_record_s": wait,
                  "blocked_per_record_s": max(0.0, np.mean([e.seconds for e in fleet]) - cpu - wait),
                  "worker_other_threads_cpu_per_record_s": max(0.0, others),
                  "calling_process_cpu_per_record_s": here / n}
        if wall < best[1]:
            best = (fleet, wall, clocks)
    return best


def warm_up(record: moli.IOData, options: moli.IdentifyOptions) -> None:
    moli.identify(record, options=options)


@contextlib.contextmanager
def cluster(workers: int, before: bool):
    import dask
    from distributed import Client, LocalCluster

    config = ({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None} if before
              else moli.fleets.dask_worker_config())
    started = time.perf_counter()
    with dask.config.set(config):
        local = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    with local, Client(local) as client:
        client.wait_for_workers(workers)
        say(f"LocalCluster of {workers} started in {time.perf_counter() - started:.1f} s")
        if before:  # moli's pause of the profiler, off: the fleet as it ran before
            with _without_pause():
                yield client
        else:
            yield client


@contextlib.contextmanager
def _without_pause():
    saved = backends.quiet_workers
    backends.quiet_workers = lambda client: contextlib.nullcontext()
    try:
        yield
    finally:
        backends.quiet_workers = saved


def main() -> None:
    args = arguments()
    args.out.mkdir(parents=True, exist_ok=True)
    counts = [int(w) for w in args.workers.split(",")]
    options = moli.IdentifyOptions()
    import dask
    import distributed
    machine = {"cpus": usable_cpus(), "python": platform.python_version(), "numpy": np.__version__,
               "dask": dask.__version__, "distributed": distributed.__version__, "moli": moli.__version__,
               "platform": platform.platform(), "load_at_start": load()}
    say(f"# fleet scaling: {machine}")
    report: dict = {"machine": machine, "arguments": {k: str(v) for k, v in vars(args).items()}, "fleets": [],
                    "chunks": []}

    records = [loop_record(seed, args.samples) for seed in range(max(counts) * args.records_per_worker)]
    warm_up(records[0], options)  # the imports, paid before the timing
    serial, t_serial, clocks = timed_fleet(1, lambda: moli.identify_many(records[:args.serial_records], options,
                                                                         n_jobs=1, progress=False))
    per_record = t_serial / args.serial_records
    reference = models(serial)
    report["serial"] = {"records": args.serial_records, "wall_s": t_serial, "per_record_s": per_record, **clocks}
    say(f"serial: {args.serial_records} records in {t_serial:.2f} s, {1e3 * per_record:.1f} ms per record; "
        + spent(clocks))

    chunk = int(args.chunk)
    one = ChunkedEstimator(INDICES, ALPHA, 2)
    start = time.perf_counter()
    for k in range(args.serial_chunks):
        one.add(*generated_chunk(k, chunk))
    t_chunks = time.perf_counter() - start
    rate_one = args.serial_chunks * chunk / t_chunks
    report["serial_chunks"] = {"chunks": args.serial_chunks, "chunk": chunk, "wall_s": t_chunks,
                               "samples_per_s": rate_one}
    say(f"one process: {args.serial_chunks} chunks of {chunk:.3g} in {t_chunks:.2f} s, {rate_one:.3g} samples/s")

    def save() -> None:  # after every row: a run cut short keeps what it measured
        report["load_at_end"] = load()
        (args.out / "fleet_scaling.json").write_text(json.dumps(report, indent=1))

    def fleet_row(backend: str, workers: int, timed: tuple, first: dict) -> None:
        fleet, wall, clocks = timed
        n = len(fleet)
        found = models(fleet)
        same = identical(reference, found) and identical(first.setdefault(workers, found), found)
        speedup = per_record * n / wall
        on_worker = float(np.mean([e.seconds for e in fleet]))
        row = {"backend": backend, "workers": workers, "records": n, "wall_s": wall, "speedup": speedup,
               "efficiency": speedup / workers, "per_record_on_worker_s": on_worker,
               "worker_over_serial": on_worker / per_record, "identical": same, "failures": len(fleet.failures),
               # cores' worth of CPU the calling process used meanwhile: near 1, it paces the fleet
               "calling_process_cores": clocks["calling_process_cpu_per_record_s"] * n / wall, **clocks}
        report["fleets"].append(row)
        say(f"{backend:24s} {workers:3d} workers: {n} records {wall:6.2f} s  speed-up {speedup:5.2f}  "
            f"efficiency {speedup / workers:4.2f}  per record on a worker {1e3 * on_worker:6.1f} ms "
            f"({on_worker / per_record:4.2f} x serial)  identical {same}\n    " + spent(clocks)
            + f" ({row['calling_process_cores']:.2f} of a core)")
        save()

    first: dict = {}
    for workers in counts:
        fleet = records[:workers * args.records_per_worker]
        moli.identify_many(fleet[:2 * workers], options, n_jobs=workers, progress=False)  # start the processes
        fleet_row("loky", workers, timed_fleet(args.repeats, lambda: moli.identify_many(
            fleet, options, n_jobs=workers, progress=False)), first)
    cases = [(w, False) for w in counts] + ([(max(counts), True)] if args.before else [])
    for workers, before in cases:
        backend = "dask, as before" if before else "dask"
        fleet = records[:workers * args.records_per_worker]
        with cluster(workers, before) as client:
            client.run(warm_up, records[0], options)  # every worker imports and runs once before the timing
            fleet_row(backend, workers, timed_fleet(args.repeats, lambda: moli.identify_many(
                fleet, options, executor=client, progress=False)), first)
            if before:
                continue
            count = workers * args.chunks_per_worker
            chunks = [partial(generated_chunk, k, chunk) for k in range(count)]
            check = estimate_chunks(chunks[:args.serial_chunks], INDICES, ALPHA, 2, client=client).model()
            expected = one.model()
            gap = max(float(np.max(np.abs(getattr(check, n) - getattr(expected, n))) / np.max(np.abs(getattr(expected, n))))
                      for n in "ABC")
            for read_once in (False, True):
                _, wall = best_of(args.repeats, lambda: estimate_chunks(chunks, INDICES, ALPHA, 2, client=client,
                                                                        read_once=read_once))
                rate = count * chunk / wall
                row = {"workers": workers, "chunks": count, "chunk": chunk, "read_once": read_once, "wall_s": wall,
                       "samples_per_s": rate, "speedup": rate / rate_one, "relative_gap": gap}
                report["chunks"].append(row)
                save()
                say(f"estimate_chunks{', read_once' if read_once else '':11s} {workers:3d} workers: {count} chunks "
                    f"{wall:6.2f} s  {rate:.3g} samples/s  speed-up {rate / rate_one:5.2f}  gap {gap:.1e}")
    save()
    print(table(report))


def spent(clocks: dict) -> str:
    ms = {key: 1e3 * value for key, value in clocks.items()}
    return (f"per record: CPU {ms['cpu_per_record_s']:.1f} ms, waiting for a CPU {ms['cpu_wait_per_record_s']:.1f}, "
            f"blocked {ms['blocked_per_record_s']:.1f}; workers' other threads {ms['worker_other_threads_cpu_per_record_s']:.1f}"
            f" ms CPU, calling process {ms['calling_process_cpu_per_record_s']:.1f} ms CPU")


def table(report: dict) -> str:
    serial = report["serial"]
    lines = [f"\nOne process: {1e3 * serial['per_record_s']:.1f} ms per record; "
             f"{report['serial_chunks']['samples_per_s']:.3g} samples/s reduced.\n",
             "| backend | workers | records | wall | speed-up | efficiency | per record on a worker | of which CPU "
             "/ waiting for a CPU / blocked | workers' other threads / calling process, CPU per record | calling process, "
             "cores | identical |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    ms = lambda r, key: f"{1e3 * r[key]:.1f}"  # noqa: E731
    s = report["serial"]
    lines.append(f"| one process | 1 | {s['records']} | {s['wall_s']:.2f} s | 1 | 1 | {ms(s, 'per_record_s')} ms | "
                 f"{ms(s, 'cpu_per_record_s')} / {ms(s, 'cpu_wait_per_record_s')} / {ms(s, 'blocked_per_record_s')} ms"
                 f" | - / - | | |")
    for r in report["fleets"]:
        lines.append(f"| {r['backend']} | {r['workers']} | {r['records']} | {r['wall_s']:.2f} s | {r['speedup']:.2f} | "
                     f"{r['efficiency']:.2f} | {ms(r, 'per_record_on_worker_s')} ms ({r['worker_over_serial']:.2f} x) | "
                     f"{ms(r, 'cpu_per_record_s')} / {ms(r, 'cpu_wait_per_record_s')} / {ms(r, 'blocked_per_record_s')} ms"
                     f" | {ms(r, 'worker_other_threads_cpu_per_record_s')} / {ms(r, 'calling_process_cpu_per_record_s')}"
                     f" ms | {r['calling_process_cores']:.2f} | {r['identical']} |")
    lines += ["", "| estimate_chunks | workers | chunks | wall | samples/s | speed-up | relative gap |",
              "|---|---|---|---|---|---|---|"]
    for r in report["chunks"]:
        lines.append(f"| {'read once' if r['read_once'] else 'read twice'} | {r['workers']} | {r['chunks']} x "
                     f"{r['chunk']:.0e} | {r['wall_s']:.2f} s | {r['samples_per_s']:.3g} | {r['speedup']:.2f} | "
                     f"{r['relative_gap']:.1e} |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
