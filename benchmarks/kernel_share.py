"""How much of an identification is numerical kernels, and how much Python around them.

Samples ``moli.identify`` with the defaults on the evaporator's paper split
(estimation 0..499, validation 500..999, nmax 15), one BLAS thread, with py-spy's
native sampler (``pip install py-spy``; it needs the right to trace a child process).
Only samples taken inside ``identify`` count, after a first identification that
imports scipy's modules. Each sample goes by the frame it was
taken in:

- linear algebra and filters: OpenBLAS/LAPACK, scipy's LAPACK wrappers, numpy's
  ``_umath_linalg``, ``lfilter`` (``_sigtools``), libm and the FFT;
- element loops: numpy's typed inner loops (``DOUBLE_add``, ``DOUBLE_matmul``, sums of
  products, ...);
- copies and allocation: libc (memcpy, malloc, free) and numpy's strided copy loops;
- Python and numpy dispatch: the interpreter, Python frames and numpy's argument
  parsing, type resolution and array creation.

The kernels are the first two; "whole / kernels" is the target ratio (at most 2).
The same ratio counting the copies as kernels is printed as a bound.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/kernel_share.py [runs]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import collections
import os
import re
import shutil
import subprocess
import sys
import tempfile
import warnings

LINEAR_ALGEBRA = ("openblas", "lapack", "_flapack", "_fblas", "_umath_linalg", "_sigtools", "libm.",
                  "pocketfft")
ELEMENT_LOOP = re.compile(r"^(DOUBLE|FLOAT|LONG|LONGLONG|INT|BOOL|CDOUBLE|UBYTE|BYTE|HALF)_|sum_of_products|matmul")
COPY = re.compile(r"^_?(aligned_)?(strided|contig|cast|swap).*(to|_)|^raw_array_assign|memcpy|memmove|memset")
INSIDE = "identify (moli/method/identification.py"
WARM_UP = "warm_up (kernel_share.py"
CATEGORIES = ("linear algebra and filters", "element loops", "copies and allocation", "Python and numpy dispatch")


def workload(runs: int) -> None:
    import moli
    from daisy_data import load

    data = load("evaporator")
    est, val = data[0:500], data[500:1000]
    warnings.simplefilter("ignore")
    warm_up(est, val)
    for _ in range(runs):
        moli.identify(est, val, nmax=15)


def warm_up(est, val) -> None:
    """One identification first, left out of the counts: it imports scipy's modules."""
    import moli

    moli.identify(est, val, nmax=15)


def category(leaf: str) -> str:
    """The category of the frame a sample was taken in (``function (library or file:line)``)."""
    name, _, where = leaf.partition(" (")
    if ".py:" in where or not where:
        return CATEGORIES[3]
    if any(lib in where for lib in LINEAR_ALGEBRA):
        return CATEGORIES[0]
    if "_multiarray_umath" in where:
        if ELEMENT_LOOP.search(name):
            return CATEGORIES[1]
        return CATEGORIES[2] if COPY.search(name) else CATEGORIES[3]
    if "libc.so" in where:
        return CATEGORIES[2]
    return CATEGORIES[3]


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    spy = shutil.which("py-spy")
    if spy is None:
        sys.exit("kernel_share.py needs py-spy: pip install py-spy")
    with tempfile.TemporaryDirectory() as folder:
        raw = os.path.join(folder, "samples.txt")
        subprocess.run([spy, "record", "--native", "--format", "raw", "--rate", "250", "--output", raw,
                        "--", sys.executable, __file__, "--workload", str(runs)],
                       check=True, capture_output=True)
        counts: collections.Counter[str] = collections.Counter()
        for line in open(raw, encoding="utf-8"):
            stack, _, number = line.rstrip("\n").rpartition(" ")
            if INSIDE in stack and WARM_UP not in stack:
                counts[category(stack.split(";")[-1])] += int(number)
    total = sum(counts.values())
    print(f"{total} samples inside identify ({runs} identifications)")
    for name in CATEGORIES:
        print(f"  {name:28s} {counts[name] / total:6.1%}")
    kernels = counts[CATEGORIES[0]] + counts[CATEGORIES[1]]
    print(f"whole / kernels: {total / kernels:.2f}; counting the copies as kernels: "
          f"{total / (kernels + counts[CATEGORIES[2]]):.2f}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--workload":
        workload(int(sys.argv[2]))
    else:
        main()
