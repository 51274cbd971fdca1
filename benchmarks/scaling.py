"""Time and peak memory against the record length N, at 3x3 and 8x8, against peers.

Every point runs in a fresh Python process (this script with ``--worker``), which reports
the seconds of the measured call and its own peak resident set size
(``ru_maxrss``: imports, the record and the call). Series:

* ``identify``  moli.identify on 70 % / 30 % of the record (default options)
* ``estimate``  moli.estimate for a fixed structure (indices 2 per output)
* ``read``      moli.read_data of a CSV file of the record
* ``cli``       ``moli fit`` on that CSV file (reading, identification, model file)
* ``sippy``     SIPPY N4SID (f = p = 20) at the plant's order
* ``nfoursid``  nfoursid (10 block rows) at the plant's order

A series stops at the first point over the time or the memory budget (the process is
killed as soon as it passes either), and the output says so; ``cli`` is not run where ``identify`` of the
same size was over budget, since it runs the same identification after reading.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/scaling.py [--quick] [--write-docs]``
(``--quick``: N up to 10^5 and a 20 s budget, a check that everything runs in a few minutes;
``--write-docs``: the JSON, plot and table into docs/figures and docs/performance.md).
"""

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DOCS = HERE.parent / "docs"
TASKS = ("identify", "estimate", "read", "cli", "sippy", "nfoursid")
SIZES = (3, 8)
FULL_N = tuple(10 ** k for k in range(3, 8))
QUICK_N = tuple(10 ** k for k in range(3, 6))
# The log-log slope of each curve is fitted over this range of N.
SLOPE_RANGE = (10 ** 4, 10 ** 6)
PLANT_ORDER_8 = 8
SEED = 0
# How often the resident size of a running point is read.
WATCH_SECONDS = 0.2
TABLE_START, TABLE_END = "<!-- scaling table -->", "<!-- end of scaling table -->"


# ---------------------------------------------------------------- records

def _plant_8x8(seed: int):
    """A stable 8-input 8-output plant of order 8: poles 0.5..0.95, random B and C."""
    import moli

    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((PLANT_ORDER_8, PLANT_ORDER_8)))
    A = q @ np.diag(np.linspace(0.5, 0.95, PLANT_ORDER_8)) @ q.T
    B = rng.standard_normal((PLANT_ORDER_8, 8))
    C = rng.standard_normal((8, PLANT_ORDER_8))
    return moli.StateSpaceModel(A, B, C)


def make_record(size: int, N: int, path: Path) -> None:
    """Writes y and u side by side, (N, 2 * size), as a .npy file."""
    import moli

    if size == 3:
        data = moli.example_data(N=N, seed=SEED)
        np.save(path, np.hstack([data.y, data.u]))
        return
    plant = _plant_8x8(SEED)
    u = np.column_stack([moli.random_binary_signal(N, 5.0, seed=SEED + j)[:, 0] for j in range(8)])
    y = plant.simulate(u)
    y += 0.1 * y.std(axis=0) * np.random.default_rng(SEED).standard_normal(y.shape)
    np.save(path, np.hstack([y, u]))


def write_csv(record: Path, size: int, path: Path) -> None:
    """The record as a CSV file: time, y1.., u1.. (pyarrow writes it in one pass)."""
    import pyarrow as pa
    import pyarrow.csv

    values = np.load(record, mmap_mode="r")
    names = [f"y{i + 1}" for i in range(size)] + [f"u{j + 1}" for j in range(size)]
    with pa.csv.CSVWriter(path, pa.schema([("time", pa.float64())] + [(n, pa.float64()) for n in names])) as writer:
        for start in range(0, len(values), 1 << 18):
            block = np.asarray(values[start:start + (1 << 18)])
            columns = [pa.array(np.arange(start, start + len(block), dtype=float))]
            columns += [pa.array(block[:, k]) for k in range(block.shape[1])]
            writer.write_batch(pa.RecordBatch.from_arrays(columns, names=["time", *names]))


# ---------------------------------------------------------------- one point

def worker(task: str, size: int, record: Path, csv: Path, workdir: Path) -> dict:
    """Runs one measured call in this (fresh) process; returns its seconds."""
    import moli

    names_y = [f"y{i + 1}" for i in range(size)]
    names_u = [f"u{j + 1}" for j in range(size)]
    order = PLANT_ORDER_8 if size == 8 else moli.example_plant().n
    # first use of each name imports its modules: done before the clock starts
    moli.identify, moli.estimate, moli.read_data, moli.filter_polynomial
    import pandas  # noqa: F401  (read_data's parser)
    if task in ("read", "cli"):
        from moli.app.cli import cli

        start = time.perf_counter()
        if task == "read":
            moli.read_data(csv, names_u, names_y)
        else:
            cli.main(["fit", str(csv), "--inputs", ",".join(names_u), "--outputs",
                      ",".join(names_y), "--out", str(workdir / "model.json")],
                     prog_name="moli", standalone_mode=False)
        return {"seconds": time.perf_counter() - start}
    values = np.load(record)
    y, u = values[:, :size], values[:, size:]
    del values
    start = time.perf_counter()
    if task == "identify":
        data = moli.IOData(y, u)
        del y, u
        moli.identify(*data.split(0.7))
    elif task == "estimate":
        data = moli.IOData(y, u)
        del y, u
        indices = (2,) * size
        moli.estimate(data, indices, moli.filter_polynomial(0.5, 0.7, indices))
    else:
        sys.path.insert(0, str(HERE))
        import peers_lib

        if task == "sippy":
            peers_lib._import_sippy()
        else:
            import nfoursid.nfoursid  # noqa: F401
        y, u = y - y.mean(axis=0), u - u.mean(axis=0)
        start = time.perf_counter()
        if task == "sippy":
            fitted = peers_lib.fit_sippy("N4SID", y, u, order)
        else:
            fitted = peers_lib.fit_nfoursid(y, u, order, 10)
        if fitted is None:
            raise RuntimeError(f"{task} returned no model")
    return {"seconds": time.perf_counter() - start}


def _resident_mb(pid: int) -> float:
    """The current resident set size of a process, from /proc (0 once it has ended)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0.0
    line = next((line for line in status.splitlines() if line.startswith("VmRSS:")), "VmRSS: 0 kB")
    return int(line.split()[1]) / 1024


def measure(task: str, size: int, record: Path, csv: Path, workdir: Path, budget_s: float,
            budget_mb: float) -> dict:
    """One point in a fresh process: seconds, peak RSS (MB), or why there is none.

    The process is killed as soon as it runs past the time budget or its resident size
    passes the memory budget, so a peer that would take the machine's memory never does.
    """
    command = [sys.executable, str(Path(__file__).resolve()), "--worker", task, str(size),
               str(record), str(csv), str(workdir)]
    wall = time.perf_counter()
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as child:
        while child.poll() is None:
            resident = _resident_mb(child.pid)
            if resident > budget_mb or time.perf_counter() - wall > budget_s:
                child.kill()
                child.wait()
                if resident > budget_mb:
                    return {"status": f"over the memory budget: killed at {resident:.0f} MB"}
                return {"status": f"over the time budget: killed after {budget_s:g} s"}
            time.sleep(WATCH_SECONDS)
        stdout, stderr = child.communicate()
    if child.returncode < 0:
        return {"status": f"killed by signal {-child.returncode}"}
    if child.returncode != 0:
        last = (stderr.strip().splitlines() or ["no message"])[-1]
        if "MemoryError" in last:
            return {"status": f"out of memory: {last[:200]}"}
        return {"status": f"failed: {last[:200]}"}
    result = json.loads(stdout.strip().splitlines()[-1])
    result["process_seconds"] = time.perf_counter() - wall
    result["status"] = "ok"
    return result


# ---------------------------------------------------------------- the run

def run(lengths: tuple[int, ...], budget_s: float, budget_mb: float, tasks: tuple[str, ...],
        workdir: Path, log) -> list[dict]:
    points: list[dict] = []
    for size in SIZES:
        stopped: dict[str, int] = {}
        for N in lengths:
            record = workdir / f"record_{size}_{N}.npy"
            csv = workdir / f"record_{size}_{N}.csv"
            for task in tasks:
                if task in stopped:
                    continue
                if task == "cli" and "identify" in stopped and stopped["identify"] <= N:
                    stopped[task] = N
                    log(f"{size}x{size} cli: not run from N = {N:.0e} on, where identify is over budget")
                    continue
                if not record.exists() or task in ("read", "cli") and not csv.exists():
                    # in a child process: a parent that once held a long record would pass
                    # its peak resident size on to every later child's ru_maxrss
                    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--make", str(size),
                                    str(N), str(record), str(csv) if task in ("read", "cli") else ""],
                                   check=True)
                point = {"task": task, "size": size, "N": N,
                         "record_mb": N * 2 * size * 8 / 1e6,
                         **measure(task, size, record, csv, workdir, budget_s, budget_mb)}
                if point["status"] == "ok" and point["peak_mb"] > budget_mb:
                    point["status"] = f"over the memory budget of {budget_mb:g} MB"
                points.append(point)
                shown = (f"{point['seconds']:9.2f} s {point['peak_mb']:8.0f} MB"
                         if "seconds" in point else "")
                log(f"{size}x{size} {task:9s} N = {N:>8d} {shown} {point['status']}")
                if point["status"] != "ok":
                    stopped[task] = N
                    log(f"{size}x{size} {task}: series stops at N = {N:.0e} ({point['status']})")
            for path in (record, csv):
                path.unlink(missing_ok=True)
    return points


def slopes(points: list[dict]) -> dict[str, dict[str, float]]:
    """Least-squares slope of log time and log peak memory against log N, over SLOPE_RANGE."""
    fitted: dict[str, dict[str, float]] = {}
    for task in TASKS:
        for size in SIZES:
            chosen = [pt for pt in points if pt["task"] == task and pt["size"] == size
                      and pt["status"] == "ok" and SLOPE_RANGE[0] <= pt["N"] <= SLOPE_RANGE[1]]
            if len(chosen) < 2:
                continue
            logn = np.log10([pt["N"] for pt in chosen])
            fitted[f"{task} {size}x{size}"] = {
                "time": float(np.polyfit(logn, np.log10([pt["seconds"] for pt in chosen]), 1)[0]),
                "memory": float(np.polyfit(logn, np.log10([pt["peak_mb"] for pt in chosen]), 1)[0]),
                "from": int(min(pt["N"] for pt in chosen)), "to": int(max(pt["N"] for pt in chosen)),
            }
    return fitted


def table(points: list[dict], lengths: tuple[int, ...]) -> str:
    """Markdown: one row per series, seconds / peak MB per N, and the ratio to identify."""
    head = "| series | " + " | ".join(f"N = 10^{int(np.log10(N))}" for N in lengths) + " |"
    rows = [head, "|---" * (len(lengths) + 1) + "|"]
    for size in SIZES:
        for task in TASKS:
            if not any(q["task"] == task and q["size"] == size for q in points):
                continue
            cells = []
            for N in lengths:
                pt = next((q for q in points if q["task"] == task and q["size"] == size and q["N"] == N), None)
                if pt is None:
                    cells.append("")
                elif pt["status"] != "ok":
                    cells.append(pt["status"].split(":")[0])
                else:
                    base = next((q for q in points if q["task"] == "identify" and q["size"] == size
                                 and q["N"] == N and q["status"] == "ok"), None)
                    ratio = (f" ({pt['seconds'] / base['seconds']:.2g}x)"
                             if base is not None and task in ("sippy", "nfoursid") else "")
                    cells.append(f"{pt['seconds']:.3g} s{ratio}, {pt['peak_mb']:.0f} MB")
            rows.append(f"| {task} {size}x{size} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def plot(points: list[dict], path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    for k, task in enumerate(TASKS):
        for size, style in zip(SIZES, ("-", "--")):
            chosen = [pt for pt in points if pt["task"] == task and pt["size"] == size and pt["status"] == "ok"]
            if not chosen:
                continue
            N = [pt["N"] for pt in chosen]
            label = f"{task} {size}x{size}"
            axes[0].loglog(N, [pt["seconds"] for pt in chosen], style, marker="o", color=f"C{k}", label=label)
            axes[1].loglog(N, [pt["peak_mb"] for pt in chosen], style, marker="o", color=f"C{k}")
    axes[0].set(xlabel="samples N", ylabel="seconds", title="time of the call")
    axes[1].set(xlabel="samples N", ylabel="peak RSS (MB)", title="peak memory of the process")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    fig.legend(loc="outside right center", fontsize=8)
    fig.savefig(path, dpi=110)


def machine() -> dict:
    import numpy
    import scipy

    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True,
                            text=True).stdout.strip()
    return {"python": platform.python_version(), "numpy": numpy.__version__, "scipy": scipy.__version__,
            "machine": platform.machine(), "cpus": os.cpu_count(), "commit": commit,
            "load_before": os.getloadavg(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}


def write_docs(table_text: str, meta: dict, fitted: dict) -> None:
    doc = DOCS / "performance.md"
    text = doc.read_text()
    lines = [table_text, "", "Log-log slopes (time, peak memory) over N = "
             f"10^{int(np.log10(SLOPE_RANGE[0]))}..10^{int(np.log10(SLOPE_RANGE[1]))}, where the "
             "series has at least two points there:", "",
             "| series | time slope | memory slope | over N |", "|---|---|---|---|"]
    lines += [f"| {name} | {s['time']:.2f} | {s['memory']:.2f} | {s['from']:.0e}..{s['to']:.0e} |"
              for name, s in fitted.items()]
    lines += ["", f"Run of {meta['date']} on commit {meta['commit']}; load average before the run "
              f"{', '.join(f'{v:.2f}' for v in meta['load_before'])}, after it "
              f"{', '.join(f'{v:.2f}' for v in meta['load_after'])}."]
    start, end = text.index(TABLE_START) + len(TABLE_START), text.index(TABLE_END)
    doc.write_text(text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N up to 10^5, budget 20 s")
    parser.add_argument("--budget-seconds", type=float, help="per point [default 150, quick 20]")
    parser.add_argument("--budget-mb", type=float, default=8000.0, help="peak RSS per point")
    parser.add_argument("--tasks", default=",".join(TASKS))
    parser.add_argument("--out", type=Path, default=Path("scaling-results"))
    parser.add_argument("--write-docs", action="store_true",
                        help="write docs/figures/scaling.{json,png} and the table of docs/performance.md")
    parser.add_argument("--worker", nargs=5, help=argparse.SUPPRESS)
    parser.add_argument("--make", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.make:
        size, N, record, csv = int(args.make[0]), int(args.make[1]), Path(args.make[2]), args.make[3]
        if not record.exists():
            make_record(size, N, record)
        if csv and not Path(csv).exists():
            write_csv(record, size, Path(csv))
        return
    if args.worker:
        task, size, record, csv, workdir = args.worker
        result = worker(task, int(size), Path(record), Path(csv), Path(workdir))
        result["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(json.dumps(result))
        return
    lengths = QUICK_N if args.quick else FULL_N
    budget_s = args.budget_seconds or (20.0 if args.quick else 150.0)
    tasks = tuple(t for t in args.tasks.split(",") if t)
    out = DOCS / "figures" if args.write_docs else args.out
    out.mkdir(parents=True, exist_ok=True)
    meta = machine()
    meta.update(budget_seconds=budget_s, budget_mb=args.budget_mb, lengths=list(lengths))
    print(f"budget per point: {budget_s:g} s, {args.budget_mb:g} MB; N = {list(lengths)}; {meta}")
    with tempfile.TemporaryDirectory(prefix="moli-scaling-") as work:
        points = run(lengths, budget_s, args.budget_mb, tasks, Path(work), lambda s: print(s, flush=True))
    meta["load_after"] = os.getloadavg()
    fitted = slopes(points)
    table_text = table(points, lengths)
    print(table_text)
    for name, s in fitted.items():
        print(f"slope {name}: time {s['time']:.2f}, memory {s['memory']:.2f} (N {s['from']}..{s['to']})")
    name = "scaling" if args.write_docs else ("scaling_quick" if args.quick else "scaling")
    (out / f"{name}.json").write_text(json.dumps({"meta": meta, "points": points, "slopes": fitted}, indent=1))
    plot(points, out / f"{name}.png")
    if args.write_docs:
        write_docs(table_text, meta, fitted)
    print(f"written: {out / (name + '.json')}, {out / (name + '.png')}")


if __name__ == "__main__":
    main()
