"""How much of an identification is numerical kernels, and how much Python around them.

Runs ``moli.identify`` with the defaults on the evaporator's paper split (estimation
0..499, validation 500..999, nmax 15), one BLAS thread, under Linux ``perf``'s CPU-clock
sampler (``perf record -e cpu-clock``, which needs no hardware counters). perf is
attached after a first identification, which imports scipy's modules, and detached when
the last one ends, so every sample is taken inside ``identify``. A sample goes by the
function the processor was executing (its leaf symbol and library):

- linear algebra and filters: OpenBLAS/LAPACK (numpy's and scipy's), scipy's LAPACK
  wrappers, numpy's ``_umath_linalg``, ``lfilter`` (``_sigtools``), libm and the FFT;
- element loops: numpy's typed inner loops (``DOUBLE_add``, ``DOUBLE_matmul``, sums of
  products, ...);
- copies and allocation: libc (memcpy, memset, malloc, free) and numpy's strided copy
  loops;
- Python and numpy dispatch: the interpreter, Python's allocator, numpy's argument
  parsing, type resolution and array creation, the kernel.

The kernels are the first two; "whole / kernels" is the target ratio (at most 2). The
same ratio counting the copies as kernels is printed as a bound. A sampler that walks
stacks from the Python side (py-spy's native mode) charged part of the time spent inside
OpenBLAS to the calling Python frames on this workload (docs/performance.md); perf's leaf
symbol needs no unwinding.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/kernel_share.py [runs]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import collections
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import warnings

LINEAR_ALGEBRA = ("openblas", "lapack", "_flapack", "_fblas", "_umath_linalg", "_sigtools", "libm.",
                  "pocketfft", "libgfortran")
ELEMENT_LOOP = re.compile(r"^(DOUBLE|FLOAT|LONG|LONGLONG|INT|BOOL|CDOUBLE|UBYTE|BYTE|HALF)_|sum_of_products|matmul")
COPY = re.compile(r"^_?(aligned_)?(strided|contig|cast|swap).*(to|_)|^raw_array_assign|memcpy|memmove|memset")
CATEGORIES = ("linear algebra and filters", "element loops", "copies and allocation", "Python and numpy dispatch")
RATE = 1999  # samples per second of CPU time


def record(runs: int, output: str) -> float:
    """Identify ``runs`` times with perf attached to this process; returns the seconds per run."""
    import moli
    from daisy_data import load

    data = load("evaporator")
    est, val = data[0:500], data[500:1000]
    warnings.simplefilter("ignore")
    moli.identify(est, val, nmax=15)             # imports scipy's modules: not sampled
    perf = subprocess.Popen(["perf", "record", "-e", "cpu-clock", "-F", str(RATE), "-p", str(os.getpid()),
                             "-o", output], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)                              # perf attaches; a sleeping process is not sampled
    start = time.perf_counter()
    for _ in range(runs):
        moli.identify(est, val, nmax=15)
    seconds = (time.perf_counter() - start) / runs
    perf.send_signal(signal.SIGINT)
    perf.wait()
    return seconds


def category(symbol: str, library: str) -> str:
    """The category of a sample taken in ``symbol`` of ``library``."""
    if any(lib in library for lib in LINEAR_ALGEBRA):
        return CATEGORIES[0]
    if "_multiarray_umath" in library:
        if ELEMENT_LOOP.search(symbol):
            return CATEGORIES[1]
        return CATEGORIES[2] if COPY.search(symbol) else CATEGORIES[3]
    if "libc.so" in library:
        return CATEGORIES[2]
    return CATEGORIES[3]


def samples(path: str) -> collections.Counter[str]:
    """Samples per category in a perf recording."""
    report = subprocess.run(["perf", "report", "-i", path, "--stdio", "--sort", "dso,sym", "-F", "sample,dso,sym"],
                            check=True, capture_output=True, text=True).stdout
    counts: collections.Counter[str] = collections.Counter()
    for line in report.splitlines():
        match = re.match(r"\s*(\d+)\s+(\S+)\s+\[[.k]\]\s+(.*)", line)   # user [.] or kernel [k]
        if match:
            counts[category(match.group(3).strip(), match.group(2))] += int(match.group(1))
    return counts


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    if shutil.which("perf") is None:
        sys.exit("kernel_share.py needs Linux perf (the linux-perf or linux-tools package)")
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "perf.data")
        seconds = record(runs, path)
        counts = samples(path)
    total = sum(counts.values())
    print(f"{total} samples inside identify ({runs} identifications, {seconds:.3f} s each)")
    for name in CATEGORIES:
        print(f"  {name:28s} {counts[name] / total:6.1%}")
    kernels = counts[CATEGORIES[0]] + counts[CATEGORIES[1]]
    print(f"whole / kernels: {total / kernels:.2f}; counting the copies as kernels: "
          f"{total / (kernels + counts[CATEGORIES[2]]):.2f}")


if __name__ == "__main__":
    main()
