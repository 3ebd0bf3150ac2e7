"""RAM init files and the manifest, written whole or not at all.

* ``<name>.hex``: one 32-bit word per line, 8 hex digits (``$readmemh`` and
  Amaranth ``Memory(init=...)``), I in the low half (see ``fixedpoint.pack_iq``);
* ``<name>.bin``: the same words, raw little-endian uint32;
* ``<name>.npy``: the unquantised complex128 period;
* ``<name>.coe``: Xilinx coefficient file (Vivado Block Memory Generator
  ``memory_initialization_vector``, radix 16), on request;
* ``<name>.mif``: Intel/Altera memory initialisation file (Quartus, WIDTH 32,
  DEPTH the stream length, hex data), on request;
* ``manifest.json``: per windmill the stream, delay and gain, plus register values.

:func:`make_farm_files` computes the streams and writes their files at once:
each piece of a period or of the words goes to a writer thread as soon as it
is final, so that writing (26.7 M words of the seed's mode make 773 MB of
files) overlaps the computation instead of following it.
"""

from __future__ import annotations

import errno
import functools
import io
import json
import mmap
import os
import shutil
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from rast.model.files.outputs import check_target, replace_file
from rast.model.physics.stream import FarmStreams, build_farm_streams

__all__ = ["write_hex", "read_hex", "write_bin", "read_bin", "write_coe", "write_mif",
           "FORMATS", "DEFAULT_FORMATS", "write_farm_files", "make_farm_files", "output_names", "check_targets"]

#: RAM file formats ``write_farm_files`` writes, by file suffix.
FORMATS = ("hex", "bin", "npy", "coe", "mif")
#: What ``rast stream`` writes without ``--format``; ``.hex`` is always written
#: (the manifest's readers, ``rast load`` and ``rast verilog --manifest``, read it).
DEFAULT_FORMATS = ("hex", "bin", "npy")
#: Words formatted at a time by the .hex writers (a 2.4 MB buffer, reused).
_HEX_BLOCK = 1 << 18
#: Threads writing files beside the computation (formatting and writing release the GIL).
_WRITERS = 2


def _check_words(words) -> np.ndarray:
    words = np.asarray(words)
    if words.dtype == np.uint32:
        return words.reshape(-1)
    words = np.asarray(words, dtype=np.int64).reshape(-1)
    if words.size and (words.min() < 0 or words.max() >= 1 << 32):
        raise ValueError("stream words must be unsigned 32-bit values")
    return words


@functools.lru_cache(maxsize=1)
def _hex_digits() -> np.ndarray:
    """The four lower-case hex digits of every 16-bit value as one little-endian
    uint32 each, the first digit in the lowest byte (as they lie in the file)."""
    value = np.arange(1 << 16)
    nibbles = np.stack([(value >> shift) & 15 for shift in (12, 8, 4, 0)], axis=1)
    digits = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)[nibbles]
    table = np.ascontiguousarray(digits).view("<u4").reshape(-1)
    table.flags.writeable = False
    return table


class _HexLines:
    """Formats words as ``.hex`` lines (eight lower-case hex digits and a newline
    each) into one reused buffer: two table look-ups per word, no Python loop."""

    def __init__(self, size: int = _HEX_BLOCK):
        self.buffer = np.full(9 * size, ord("\n"), dtype=np.uint8)
        # (high, low) halves' digits of line k at bytes 9k … 9k + 7; byte 9k + 8 stays '\n'.
        self.digits = np.ndarray((size, 2), dtype="<u4", buffer=self.buffer, strides=(9, 4))
        self.half = np.empty(size, dtype=np.uint32)

    def __call__(self, words: np.ndarray) -> np.ndarray:
        """The lines of ``words`` (at most ``size`` unsigned 32-bit values), a view of the buffer."""
        n = words.size
        words = words.astype(np.uint32, copy=False)
        table, half = _hex_digits(), self.half[:n]
        np.right_shift(words, 16, out=half)
        np.take(table, half, out=self.digits[:n, 0])
        np.bitwise_and(words, 0xFFFF, out=half)
        np.take(table, half, out=self.digits[:n, 1])
        return self.buffer[:9 * n]


def write_hex(words, path) -> None:
    """``$readmemh`` file: one word per line, eight lower-case hex digits."""
    words = _check_words(words)
    lines = _HexLines(min(words.size, _HEX_BLOCK))
    with open(path, "wb") as f:
        for start in range(0, words.size, _HEX_BLOCK):
            f.write(lines(words[start:start + _HEX_BLOCK]))


def read_hex(path) -> np.ndarray:
    """Read a ``$readmemh`` file of one word per line back as int64."""
    lines = [line.strip() for line in Path(path).read_text(encoding="ascii").splitlines()]
    return np.array([int(line, 16) for line in lines if line], dtype=np.int64)


def write_bin(words, path) -> None:
    np.asarray(words, dtype="<u4").tofile(path)


def read_bin(path) -> np.ndarray:
    return np.fromfile(path, dtype="<u4").astype(np.int64)


def write_coe(words, path, comment: str = "") -> None:
    """Xilinx ``.coe``: ``memory_initialization_radix=16;`` then the vector, one
    8-digit word per line, separated by commas and ended by a semicolon."""
    words = _check_words(words)
    if not words.size:
        raise ValueError("a .coe file needs at least one word")
    head = "".join(f"; {line}\n" for line in comment.splitlines())
    body = ",\n".join(f"{int(w):08x}" for w in words)
    Path(path).write_text(f"{head}memory_initialization_radix=16;\nmemory_initialization_vector=\n{body};\n",
                          encoding="ascii")


def write_mif(words, path, comment: str = "") -> None:
    """Intel ``.mif``: WIDTH=32, DEPTH = the number of words, unsigned decimal
    addresses, hex data, one ``address : word;`` line each."""
    words = _check_words(words)
    head = "".join(f"-- {line}\n" for line in comment.splitlines())
    body = "".join(f"\t{k} : {int(w):08X};\n" for k, w in enumerate(words))
    Path(path).write_text(f"{head}WIDTH=32;\nDEPTH={words.size};\n\nADDRESS_RADIX=UNS;\nDATA_RADIX=HEX;\n\n"
                          f"CONTENT BEGIN\n{body}END;\n", encoding="ascii")


def _chosen(formats) -> list[str]:
    """The formats to write, in FORMATS order, ``hex`` always; ValueError for an unknown one."""
    formats = DEFAULT_FORMATS if formats is None else formats
    unknown = set(formats) - set(FORMATS)
    if unknown:
        raise ValueError(f"unknown RAM file format(s) {sorted(unknown)}; known: {', '.join(FORMATS)}")
    return [f for f in FORMATS if f in set(formats) | {"hex"}]


def _comment(name: str, length: int) -> str:
    return (f"rast stream: windmill {name}, {length} words of 32 bits, "
            "I in bits 15..0, Q in bits 31..16 (signed 16-bit)")


def _npy_header(length: int) -> bytes:
    """The ``.npy`` header ``np.save`` writes for a complex128 vector of ``length`` values."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": np.lib.format.dtype_to_descr(np.dtype(complex)), "fortran_order": False,
                 "shape": (length,)})
    return header.getvalue()


#: Files of at least this size bypass the page cache (see _OutFile).
_DIRECT_MIN_BYTES = 64 << 20
#: O_DIRECT transfers: offsets, lengths and the buffer aligned to this (a page; every
#: common device's logical block divides it).
_ALIGN = 4096
#: Bytes gathered before one O_DIRECT write.
_DIRECT_BUFFER = 4 << 20


class _OutFile:
    """A file written front to back, in pieces.

    A large one is written with ``O_DIRECT`` through an aligned buffer: its
    bytes go to the device without passing through the page cache. On the
    development machine (a virtual machine whose fresh memory is slow to map)
    filling fresh page cache took 2 to 4 s per GB, ``O_DIRECT`` 0.4 s per GB;
    the files are written once and read later, if at all. Small files, systems
    without ``O_DIRECT`` and file systems that refuse it get plain writes.
    """

    def __init__(self, path, size: int):
        self.path = path
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0)
        self.fd = None
        if size >= _DIRECT_MIN_BYTES and hasattr(os, "O_DIRECT"):
            try:
                self.fd = os.open(path, flags | os.O_DIRECT, 0o666)
            except OSError:                    # e.g. tmpfs: EINVAL
                pass
        self.direct = self.fd is not None
        if self.fd is None:
            self.fd = os.open(path, flags, 0o666)
        self.offset = 0                        # bytes handed to the file system so far
        self.size = 0                          # bytes written by the caller so far
        if self.direct:
            self.map = mmap.mmap(-1, _DIRECT_BUFFER)        # page-aligned
            self.buffer = np.frombuffer(self.map, dtype=np.uint8)
            self.fill = 0

    def write(self, data) -> None:
        view = memoryview(data).cast("B")
        self.size += len(view)
        while view and self.direct:
            n = min(len(view), _DIRECT_BUFFER - self.fill)
            self.buffer[self.fill:self.fill + n] = np.frombuffer(view[:n], dtype=np.uint8)
            self.fill += n
            view = view[n:]
            if self.fill == _DIRECT_BUFFER:
                self._put(memoryview(self.map))
                self.fill = 0
        if view:                                 # plain writes: from the start, or since
            self._put_buffered()                 # O_DIRECT was refused (what it holds first)
            self._put(view)

    def _put_buffered(self) -> None:
        if getattr(self, "fill", 0):
            self._put(memoryview(self.map)[:self.fill])
            self.fill = 0

    def _put(self, view) -> None:
        while view:
            try:
                done = os.write(self.fd, view)
            except OSError as error:
                if not (self.direct and error.errno == errno.EINVAL):
                    raise
                os.close(self.fd)                # O_DIRECT refused at the first write
                self.fd = os.open(self.path, os.O_WRONLY | getattr(os, "O_BINARY", 0))
                os.lseek(self.fd, self.offset, os.SEEK_SET)
                self.direct = False
                continue
            view, self.offset = view[done:], self.offset + done

    def close(self) -> None:
        try:
            if self.direct and self.fill:       # the tail, padded to a whole block, then cut
                padded = -(-self.fill // _ALIGN) * _ALIGN
                self.buffer[self.fill:padded] = 0
                self._put(memoryview(self.map)[:padded])
                os.ftruncate(self.fd, self.size)
            else:
                self._put_buffered()
        finally:
            os.close(self.fd)
            if hasattr(self, "map"):
                self.buffer = None
                self.map.close()


def _write_words(out: _OutFile, words: np.ndarray, kind: str, lines: _HexLines | None = None) -> None:
    """Append ``words`` to a ``.hex`` or ``.bin`` file."""
    if kind == "bin":
        out.write(np.ascontiguousarray(words, dtype="<u4"))
        return
    lines = lines or _HexLines(min(words.size, _HEX_BLOCK))
    for k in range(0, words.size, _HEX_BLOCK):
        out.write(lines(words[k:k + _HEX_BLOCK]))


def _write_file(path, size: int, write, *args) -> None:
    """``write(file, *args)`` into a new :class:`_OutFile` of about ``size`` bytes."""
    out = _OutFile(path, size)
    try:
        write(out, *args)
    finally:
        out.close()


class _StreamFiles:
    """The sink of :func:`build_farm_streams` for :func:`make_farm_files`: each piece of a
    period (``.npy``) and of the words (``.bin``, ``.hex``) is written by a writer thread
    while the rest is computed, one thread for the periods and one for the words, so
    that every file gets its pieces in order."""

    def __init__(self, folder: Path, chosen: list[str], progress=None):
        self.folder, self.chosen, self.progress = folder, chosen, progress
        self.periods = ThreadPoolExecutor(1)
        self.words_pool = ThreadPoolExecutor(1)
        self.lock = threading.Lock()
        self.files: dict[str, dict[str, _OutFile]] = {}    # windmill → format → file
        self.done: dict[str, list[int]] = {}                # windmill → [samples computed, words written]
        self.lengths: dict[str, int] = {}
        self.futures = []
        self.lines = None                                   # the words thread's hex buffer

    def start(self, windmill, length: int) -> None:
        name = windmill.name
        sizes = {"hex": 9 * length, "bin": 4 * length, "npy": len(_npy_header(length)) + 16 * length}
        files = {f: _OutFile(self.folder / f"{name}.{f}", sizes[f]) for f in ("hex", "bin", "npy")
                 if f in self.chosen}
        with self.lock:
            self.files[name] = files
            self.done[name] = [0, 0]
            self.lengths[name] = length
        if "npy" in files:
            files["npy"].write(_npy_header(length))

    def _submit(self, pool, fn, *args) -> None:
        future = pool.submit(fn, *args)
        with self.lock:
            self.futures.append(future)

    def period(self, windmill, start: int, values: np.ndarray) -> None:
        if "npy" in self.files[windmill.name]:
            self._submit(self.periods, self.files[windmill.name]["npy"].write, values)
        self._count(windmill.name, 0, len(values))

    def words(self, windmill, start: int, words: np.ndarray) -> None:
        self._submit(self.words_pool, self._words, windmill.name, words)

    def _words(self, name: str, words: np.ndarray) -> None:
        if self.lines is None:
            self.lines = _HexLines()
        for kind in ("bin", "hex"):
            if kind in self.files[name]:
                _write_words(self.files[name][kind], words, kind, self.lines)
        self._count(name, 1, words.size)

    def _count(self, name: str, stage: int, count: int) -> None:
        if self.progress is None:
            return
        with self.lock:
            done = self.done[name]
            done[stage] += count
            half = (done[0] + done[1]) // 2
        self.progress(name, half, self.lengths[name])

    def close(self, report: bool = True) -> None:
        """Wait for every write and close the files; raises the first error (if ``report``)."""
        for pool in (self.periods, self.words_pool):
            pool.shutdown(wait=True, cancel_futures=not report)
        errors = [f.exception() for f in self.futures if not f.cancelled() and f.exception()]
        for files in self.files.values():
            for out in files.values():
                try:
                    out.close()
                except OSError as error:
                    errors.append(error)
        if report and errors:
            raise errors[0]


def output_names(windmill_names, formats=DEFAULT_FORMATS) -> list[str]:
    """The files a farm's streams are written to: per windmill one per format
    (``.hex`` always), and ``manifest.json``."""
    chosen = _chosen(formats)
    return [f"{name}.{f}" for name in windmill_names for f in chosen] + ["manifest.json"]


def check_targets(out_dir, windmill_names, formats=DEFAULT_FORMATS) -> None:
    """Refuse (:class:`OutputError`) an output folder in which one of the files
    a farm would be written to exists as something else than a regular file
    (a folder, a device): before any is computed or written, so that the
    earlier outputs stay whole."""
    for name in output_names(windmill_names, formats):
        check_target(Path(out_dir) / name)


def _commit(farm_streams: FarmStreams, staging: Path, out_dir: Path, names: dict, build) -> dict[str, Path]:
    """Write the manifest into ``staging`` and move every file into ``out_dir``
    (every target checked first: one that is not a regular file moves none)."""
    manifest = farm_streams.manifest(names)
    if build is not None:
        manifest["build"] = build.to_dict()
    (staging / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    files = sorted(staging.iterdir())
    for path in files:
        check_target(out_dir / path.name)
    written = {}
    for path in files:
        target = out_dir / path.name
        replace_file(path, target)
        written[path.name] = target
    return written


def make_farm_files(farm, out_dir, *, build=None, formats=DEFAULT_FORMATS, progress=None,
                    check=None) -> tuple[FarmStreams, dict[str, Path]]:
    """Compute the farm's streams (:func:`build_farm_streams`) and write their files
    (as :func:`write_farm_files`, the same bytes) while they are computed.

    ``progress(name, done, total)`` counts, per windmill, half a sample for each
    sample of the period computed and half for each word written. ``check(farm_streams)``
    is called once the streams are made, before any file is moved into ``out_dir``:
    an exception it raises leaves ``out_dir`` as it was, as does any other failure
    (folders this call created are removed again). Returns the streams and the
    written paths by file name.
    """
    chosen = _chosen(formats)
    out_dir = Path(out_dir)
    check_targets(out_dir, [w.name for w in farm.windmills], formats)
    created = [p for p in (out_dir, *out_dir.parents) if not p.exists()]
    out_dir.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".rast-staging-", dir=out_dir))
    try:
        sink = _StreamFiles(staging, chosen, progress)
        try:
            farm_streams = build_farm_streams(farm, sink=sink)
        except BaseException:
            sink.close(report=False)
            raise
        sink.close()
        if check is not None:
            check(farm_streams)
        names = {}
        for s in farm_streams.streams:
            name = s.windmill.name
            names[name] = {f"{f}_file": f"{name}.{f}" for f in chosen}
            comment = _comment(name, s.plan.length)
            if "coe" in chosen:
                write_coe(s.packed, staging / f"{name}.coe", comment)
            if "mif" in chosen:
                write_mif(s.packed, staging / f"{name}.mif", comment)
        return farm_streams, _commit(farm_streams, staging, out_dir, names, build)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        for folder in created:                 # innermost first; only while empty
            try:
                folder.rmdir()
            except OSError:
                break
        raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def write_farm_files(farm_streams: FarmStreams, out_dir, *, build=None,
                     formats=DEFAULT_FORMATS) -> dict[str, Path]:
    """Write every stream's files (``formats``, a subset of :data:`FORMATS`; ``hex``
    is always written) and the manifest into ``out_dir``.

    ``build`` (a :class:`ReplayContract`) is recorded in the manifest as the
    build the streams were sized for.

    The files are written into a staging folder beside ``out_dir`` first and
    moved into place only when all of them are complete, so a failure leaves
    ``out_dir`` as it was. Returns the written paths by file name.
    """
    out_dir = Path(out_dir)
    check_targets(out_dir, [s.windmill.name for s in farm_streams.streams], formats)
    out_dir.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".rast-staging-", dir=out_dir))
    try:
        names = {}
        chosen = _chosen(formats)
        jobs = []
        for s in farm_streams.streams:
            name = s.windmill.name
            files = {f"{f}_file": f"{name}.{f}" for f in chosen}
            comment = _comment(name, s.plan.length)
            words = s.words_u32()
            period = np.asanyarray(s.period)
            writers = {"hex": lambda p, w=words: _write_file(p, 9 * w.size, _write_words, w, "hex"),
                       "bin": lambda p, w=words: _write_file(p, 4 * w.size, _write_words, w, "bin"),
                       # np.save's own writer, into the same kind of file: the same bytes
                       "npy": lambda p, v=period: _write_file(p, v.nbytes, np.lib.format.write_array, v),
                       "coe": lambda p, w=words, c=comment: write_coe(w, p, c),
                       "mif": lambda p, w=words, c=comment: write_mif(w, p, c)}
            jobs += [(writers[f], staging / files[f"{f}_file"]) for f in chosen]
            names[name] = files
        # Formatting and writing release the GIL: two files at a time.
        with ThreadPoolExecutor(max_workers=_WRITERS) as pool:
            for done in [pool.submit(job, *job_args) for job, *job_args in jobs]:
                done.result()
        return _commit(farm_streams, staging, out_dir, names, build)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
