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
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .stream import FarmStreams

__all__ = ["write_hex", "read_hex", "write_bin", "read_bin", "write_coe", "write_mif",
           "FORMATS", "DEFAULT_FORMATS", "write_farm_files"]

#: RAM file formats ``write_farm_files`` writes, by file suffix.
FORMATS = ("hex", "bin", "npy", "coe", "mif")
#: What ``rast stream`` writes without ``--format``; ``.hex`` is always written
#: (the manifest's readers, ``rast load`` and ``rast verilog --manifest``, read it).
DEFAULT_FORMATS = ("hex", "bin", "npy")
#: Words formatted at a time by write_hex.
_HEX_BLOCK = 1 << 20


def _check_words(words) -> np.ndarray:
    words = np.asarray(words)
    if words.dtype == np.uint32:
        return words.reshape(-1)
    words = np.asarray(words, dtype=np.int64).reshape(-1)
    if words.size and (words.min() < 0 or words.max() >= 1 << 32):
        raise ValueError("stream words must be unsigned 32-bit values")
    return words


def write_hex(words, path) -> None:
    words = _check_words(words)
    # Eight lower-case hex digits and a newline per word: bytes.hex of the
    # big-endian words with a separator every 4 bytes, in blocks.
    with open(path, "wb") as f:
        for start in range(0, words.size, _HEX_BLOCK):
            block = words[start:start + _HEX_BLOCK].astype(">u4")
            f.write(block.tobytes().hex("\n", 4).encode("ascii"))
            f.write(b"\n")


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
    out_dir.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".rast-staging-", dir=out_dir))
    try:
        names = {}
        formats = DEFAULT_FORMATS if formats is None else formats
        unknown = set(formats) - set(FORMATS)
        if unknown:
            raise ValueError(f"unknown RAM file format(s) {sorted(unknown)}; known: {', '.join(FORMATS)}")
        chosen = [f for f in FORMATS if f in set(formats) | {"hex"}]
        jobs = []
        for s in farm_streams.streams:
            name = s.windmill.name
            files = {f"{f}_file": f"{name}.{f}" for f in chosen}
            comment = (f"rast stream: windmill {name}, {s.plan.length} words of 32 bits, "
                       "I in bits 15..0, Q in bits 31..16 (signed 16-bit)")
            words = s.words_u32()
            writers = {"hex": lambda p, w=words: write_hex(w, p),
                       "bin": lambda p, w=words: write_bin(w, p),
                       "npy": lambda p, v=s.period: np.save(p, v),
                       "coe": lambda p, w=words, c=comment: write_coe(w, p, c),
                       "mif": lambda p, w=words, c=comment: write_mif(w, p, c)}
            jobs += [(writers[f], staging / files[f"{f}_file"]) for f in chosen]
            names[name] = files
        # Formatting and writing release the GIL: two files at a time.
        with ThreadPoolExecutor(max_workers=2) as pool:
            for done in [pool.submit(job, *job_args) for job, *job_args in jobs]:
                done.result()
        manifest = farm_streams.manifest(names)
        if build is not None:
            manifest["build"] = build.to_dict()
        (staging / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
        written = {}
        for path in sorted(staging.iterdir()):
            target = out_dir / path.name
            os.replace(path, target)
            written[path.name] = target
        return written
    finally:
        shutil.rmtree(staging, ignore_errors=True)
