"""Files that are small on disk and huge once read, and a reader run under an address-space cap.

Each bomb holds a record of a few hundred samples beside content that inflates to
``size`` bytes of zeros. The zeros are deflated once per block and the compressed block
repeated (each block starts after a full flush, so it references only itself), which
makes a multi-GiB array in well under a second and a few MiB of disk.
"""

from __future__ import annotations

import io
import json
import os
import struct
import subprocess
import sys
import textwrap
import zipfile
import zlib
from pathlib import Path
from typing import Iterator

import numpy as np

import moli

# The address space a capped reader may use, as the checks of docs/data.md state it.
CAP_BYTES = 2 << 30
# Zeros deflated at a time: one block's compression is the only real work.
BLOCK = 1 << 24
SAMPLES = 300


def record() -> tuple[np.ndarray, np.ndarray]:
    """A seeded SISO record (u, y) of :data:`SAMPLES` samples, as (N, 1) columns."""
    u = np.random.default_rng(0).standard_normal((SAMPLES, 1))
    y = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]]).simulate(u)
    return u, y


def _deflated(size: int, fill: bytes = b"\0") -> Iterator[bytes]:
    """Raw deflate blocks (none final) that inflate to ``size`` bytes ``fill``."""
    whole, rest = divmod(size, BLOCK)
    for count, length in ((whole, BLOCK), (1, rest)):
        if count and length:
            packer = zlib.compressobj(9, zlib.DEFLATED, -15)
            block = packer.compress(fill * length) + packer.flush(zlib.Z_FULL_FLUSH)
            yield from (block for _ in range(count))


def _crc32(prefix: bytes, size: int, fill: bytes = b"\0", suffix: bytes = b"") -> int:
    value = zlib.crc32(prefix)
    block = fill * BLOCK
    for start in range(0, size, BLOCK):
        value = zlib.crc32(block[: size - start], value)
    return zlib.crc32(suffix, value)


def _adler32(prefix: bytes, zeros: int) -> int:
    """Adler-32 of ``prefix`` and ``zeros`` zero bytes: a zero adds nothing to the byte sum
    and the byte sum to the running sum (RFC 1950)."""
    value = zlib.adler32(prefix)
    low, high = value & 0xFFFF, value >> 16
    return ((high + zeros * low) % 65521) << 16 | low


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, np.asarray(array))
    return buffer.getvalue()


def bomb_npz(path: Path, size: int, with_record: bool = True) -> Path:
    """An ``.npz`` with ``u``, ``y``, ``Ts`` (or, ``with_record=False``, ``u1``, ``y1``)
    and an array ``junk`` that inflates to ``size`` bytes (under 4 GiB: no zip64 needed)."""
    u, y = record()
    arrays = {"u": u, "y": y, "Ts": np.float64(0.5)} if with_record else {"u1": u[:, 0], "y1": y[:, 0]}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        for name, array in arrays.items():
            archive.writestr(f"{name}.npy", _npy(array))
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False,
                                                  "shape": (size // 8,)})
    _append_member(path, "junk.npy", header.getvalue(), size // 8 * 8)
    return path


def _append_member(path: Path, name: str, prefix: bytes, size: int, fill: bytes = b"\0",
                   suffix: bytes = b"") -> None:
    """Append a deflated member ``prefix + fill * size + suffix`` to a zip file (under 4 GiB
    in all: no zip64), rewriting its central directory."""
    with zipfile.ZipFile(path) as archive:
        entries = archive.infolist()
        start = archive.start_dir
    packer, closer = zlib.compressobj(9, zlib.DEFLATED, -15), zlib.compressobj(9, zlib.DEFLATED, -15)
    body = [packer.compress(prefix) + packer.flush(zlib.Z_FULL_FLUSH), *_deflated(size, fill),
            closer.compress(suffix) + closer.flush()]
    raw = name.encode()
    fields = struct.pack("<HHHHHIII", 20, 0, 8, 0, 0x21, _crc32(prefix, size, fill, suffix),
                         sum(map(len, body)), len(prefix) + size + len(suffix))
    with path.open("r+b") as handle:
        handle.seek(start)
        directory = handle.read()
        handle.seek(start)
        handle.truncate()
        handle.write(b"PK\x03\x04" + fields + struct.pack("<HH", len(raw), 0) + raw)
        for piece in body:
            handle.write(piece)
        offset = handle.tell()
        handle.write(directory[: directory.rindex(b"PK\x05\x06")])
        handle.write(b"PK\x01\x02" + struct.pack("<H", 20) + fields
                     + struct.pack("<HHHHHII", len(raw), 0, 0, 0, 0, 0, start) + raw)
        handle.write(b"PK\x05\x06" + struct.pack("<HHHHIIH", 0, 0, len(entries) + 1, len(entries) + 1,
                                                handle.tell() - offset, offset, 0))


def _element(kind: int, data: bytes) -> bytes:
    """A MATLAB level-5 data element: tag, data, padding to 8 bytes."""
    return struct.pack("<II", kind, len(data)) + data + bytes(-len(data) % 8)


def _matrix_head(class_id: int, dims: tuple[int, int], name: str, body_bytes: int) -> bytes:
    """A miMATRIX element's tag and sub-elements up to its data, which take ``body_bytes``."""
    parts = (_element(6, struct.pack("<II", class_id, 0)) + _element(5, struct.pack("<ii", *dims))
             + _element(1, name.encode()))
    return struct.pack("<II", 14, len(parts) + body_bytes) + parts


def bomb_mat(path: Path, size: int, as_struct: bool = False, with_record: bool = True) -> Path:
    """A ``.mat`` with ``u``, ``y``, ``Ts`` (or ``u1``, ``y1``) and a compressed variable
    ``junk`` (a double column, or a struct whose field ``data`` is one) of ``size`` bytes."""
    from scipy.io import savemat

    u, y = record()
    variables = {"u": u, "y": y, "Ts": 0.5} if with_record else {"u1": u, "y1": y}
    savemat(path, variables, do_compression=True)
    rows = size // 8
    column = struct.pack("<II", 9, rows * 8)            # miDOUBLE tag; the zeros follow
    if as_struct:
        field = _matrix_head(6, (rows, 1), "", len(column) + rows * 8)
        names = _element(5, struct.pack("<i", 32)) + _element(1, b"data".ljust(32, b"\0"))
        prefix = _matrix_head(2, (1, 1), "junk", len(names) + len(field) + len(column) + rows * 8) + names + field
    else:
        prefix = _matrix_head(6, (rows, 1), "junk", len(column) + rows * 8)
    prefix += column
    packer = zlib.compressobj(9, zlib.DEFLATED, 15)
    body = [packer.compress(prefix) + packer.flush(zlib.Z_FULL_FLUSH), *_deflated(rows * 8), b"\x03\x00",
            struct.pack(">I", _adler32(prefix, rows * 8))]
    with path.open("ab") as handle:
        handle.write(struct.pack("<II", 15, sum(map(len, body))))
        for piece in body:
            handle.write(piece)
    return path


SHEET = "xl/worksheets/sheet1.xml"
MAIN = "http://schemas.openxmlformats.org/spreadsheetml/2006/main"


def _cell(reference: str, value: object) -> str:
    if isinstance(value, int):   # an index into the shared strings
        return f'<c r="{reference}" t="s"><v>{value}</v></c>'
    return f'<c r="{reference}"><v>{value!r}</v></c>'


def bomb_xlsx(path: Path, size: int, shared: bool) -> Path:
    """A workbook of columns ``u1``, ``y1`` and ``note``, whose note on the first data row
    is ``size`` letters: in the sheet itself, or (``shared``) in the workbook's shared
    strings, where the header's names are too."""
    from openpyxl import Workbook

    Workbook().save(path)   # the workbook's other parts, as openpyxl writes them
    with zipfile.ZipFile(path) as base:
        parts = {item.filename: base.read(item.filename) for item in base.infolist()}
    u, y = record()
    header = "".join(_cell(f"{c}1", k + 1 if shared else 0) for k, c in enumerate("ABC"))
    rows = [f'<row r="{k + 2}">{_cell(f"A{k + 2}", float(a))}{_cell(f"B{k + 2}", float(b))}' for k, (a, b)
            in enumerate(zip(u[:, 0], y[:, 0]))]
    sheet_head = f'<worksheet xmlns="{MAIN}"><sheetData><row r="1">{header}</row>'
    sheet_tail = "</row>".join(rows[1:]) + "</row></sheetData></worksheet>"
    names = "".join(f"<si><t>{name}</t></si>" for name in ("u1", "y1", "note"))
    if shared:
        parts[SHEET] = (sheet_head + rows[0] + '<c r="C2" t="s"><v>0</v></c></row>' + sheet_tail).encode()
        parts["[Content_Types].xml"] = parts["[Content_Types].xml"].replace(
            b"</Types>", b'<Override PartName="/xl/sharedStrings.xml" ContentType="application/'
            b'vnd.openxmlformats-officedocument.spreadsheetml.sharedStrings+xml"/></Types>')
        member = ("xl/sharedStrings.xml", f'<sst xmlns="{MAIN}"><si><t>', f"</t></si>{names}</sst>")
    else:
        header = "".join(f'<c r="{c}1" t="inlineStr"><is><t>{name}</t></is></c>'
                         for c, name in zip("ABC", ("u1", "y1", "note")))
        sheet_head = f'<worksheet xmlns="{MAIN}"><sheetData><row r="1">{header}</row>'
        del parts[SHEET]
        member = (SHEET, sheet_head + rows[0] + '<c r="C2" t="inlineStr"><is><t>', "</t></is></c></row>" + sheet_tail)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, content in parts.items():
            archive.writestr(name, content)
    _append_member(path, member[0], member[1].encode(), size, b"x", member[2].encode())
    return path


# Reads a file under the cap and prints the record (or the moli error) as one JSON line.
CAPPED = textwrap.dedent("""
    import json, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
    import moli
    arguments = json.loads(sys.argv[2])
    try:
        data = moli.read_data(sys.argv[1], *arguments)
    except moli.MoliError as exc:
        print(json.dumps({{"error": type(exc).__name__ + ": " + str(exc)}}))
    else:
        print(json.dumps({{"u": data.u.tolist(), "y": data.y.tolist(), "Ts": data.Ts}}))
""")


def read_capped(path: Path, *arguments: object, cap: int = CAP_BYTES) -> dict:
    """``moli.read_data(path, *arguments)`` in a process whose address space is capped.

    Returns the record's ``u``, ``y``, ``Ts``, or ``error``: a moli error's text; anything
    else (a traceback, a kill) fails with the process's output.
    """
    done = subprocess.run(
        [sys.executable, "-c", CAPPED.format(cap=cap), str(path), json.dumps(arguments)],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore",
             "PYTHONPATH": str(Path(moli.__file__).parents[1])})
    assert done.returncode == 0 and done.stdout.strip(), (done.returncode, done.stdout[-2000:], done.stderr[-4000:])
    return json.loads(done.stdout.strip().splitlines()[-1])


def zero_padded_csv(path: Path, size: int, encoding: str = "utf-8") -> Path:
    """A CSV of the record followed by ``size`` zero bytes (a sparse file: nothing on disk),
    as a logger's file looks after a crash."""
    u, y = record()
    text = "u1,y1\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(u[:, 0].tolist(), y[:, 0].tolist()))
    with path.open("wb") as handle:
        handle.write(text.encode(encoding))
        handle.truncate(handle.tell() + size)
    return path
