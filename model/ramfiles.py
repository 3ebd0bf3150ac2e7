"""RAM init files and the manifest, written whole or not at all.

* ``<name>.hex``: one 32-bit word per line, 8 hex digits (``$readmemh`` and
  Amaranth ``Memory(init=...)``), I in the low half (see ``fixedpoint.pack_iq``);
* ``<name>.bin``: the same words, raw little-endian uint32;
* ``<name>.npy``: the unquantised complex128 period;
* ``manifest.json``: per windmill the stream, delay and gain, plus register values.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from .stream import FarmStreams

__all__ = ["write_hex", "read_hex", "write_bin", "read_bin", "write_farm_files"]


def write_hex(words, path) -> None:
    words = np.asarray(words, dtype=np.int64)
    if words.size and (words.min() < 0 or words.max() >= 1 << 32):
        raise ValueError("stream words must be unsigned 32-bit values")
    Path(path).write_text("".join(f"{int(w):08x}\n" for w in words), encoding="ascii")


def read_hex(path) -> np.ndarray:
    """Read a ``$readmemh`` file of one word per line back as int64."""
    lines = [line.strip() for line in Path(path).read_text(encoding="ascii").splitlines()]
    return np.array([int(line, 16) for line in lines if line], dtype=np.int64)


def write_bin(words, path) -> None:
    np.asarray(words, dtype="<u4").tofile(path)


def read_bin(path) -> np.ndarray:
    return np.fromfile(path, dtype="<u4").astype(np.int64)


def write_farm_files(farm_streams: FarmStreams, out_dir, *, build=None) -> dict[str, Path]:
    """Write every stream's files and the manifest into ``out_dir``.

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
        for s in farm_streams.streams:
            name = s.windmill.name
            files = {"hex_file": f"{name}.hex", "bin_file": f"{name}.bin", "npy_file": f"{name}.npy"}
            write_hex(s.words, staging / files["hex_file"])
            write_bin(s.words, staging / files["bin_file"])
            np.save(staging / files["npy_file"], s.period)
            names[name] = files
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
