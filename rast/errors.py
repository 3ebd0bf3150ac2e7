"""User errors of the ``rast`` commands, and the readers of the files users name.

A :class:`UserError` is a mistake in the command line or in a file it names;
``rast.cli.main`` prints it as ``rast <command>: <message>`` and exits with
status 2. Anything else that escapes a command is a bug and keeps its
traceback. The readers here turn missing or malformed input into a
:class:`UserError` naming the file, before any output is created.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from rast.model.contract.regmap import stream_crc32

__all__ = ["UserError", "read_json", "read_manifest", "manifest_streams", "check_output"]

_HEX_WORD = re.compile(r"[0-9a-fA-F]{1,8}")


class UserError(Exception):
    """A mistake in the arguments or input files of a ``rast`` command."""


def read_json(path, what: str):
    """The JSON value in ``path``; ``what`` names the file in messages ("manifest", ...)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise UserError(f"cannot read the {what} {path}: {error.strerror or error}") from None
    except UnicodeDecodeError:
        raise UserError(f"the {what} {path} is not a text file") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise UserError(f"the {what} {path} is not valid JSON: {error}") from None


def _need(cond: bool, where: str, problem: str):
    if not cond:
        raise UserError(f"{where}: {problem}")


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def read_build(path):
    """The replay block a bitstream was built for: ``report.json``'s ``build``
    (written by ``rast build``), as a :class:`ReplayContract`."""
    from rast.model.contract.fixedpoint import ReplayContract
    report = read_json(path, "build report")
    build = report.get("build") if isinstance(report, dict) else None
    _need(isinstance(build, dict), str(path), "has no 'build' section: give the report.json "
          "that `rast build` wrote for the bitstream")
    # (a report from before the antenna scan, START or following existed has none: off)
    missing = [k for k in ReplayContract.PARAMETERS if k not in build
               and k not in ("scan", "start_frac", "follow_rows")]
    _need(not missing, str(path), f"its 'build' section lacks {', '.join(missing)}: give the report.json "
          "that `rast build` wrote for the bitstream")
    try:
        contract = ReplayContract.from_dict(build)
    except (TypeError, ValueError) as error:
        raise UserError(f"{path}: its 'build' section is not a replay block: {error}") from None
    _need(contract.sample_rate_hz > 0, str(path), "its 'build' section states no sample rate "
          "(sample_rate_hz 0): it is not a bitstream's report")
    return contract


def read_manifest(path) -> tuple[dict, Path]:
    """Read and check the shape of a ``rast stream`` manifest.

    ``path`` is the ``manifest.json`` or the folder holding it. Returns
    ``(manifest, file)``; the file's folder holds the stream files. Checks what
    the loaders read (every windmill's ``name``, ``hex_file`` and ``length``;
    every channel's ``windmill``, naming a listed windmill, and ``length``,
    ``phase_increment``, ``gain`` and ``delay_samples`` as integers); whether
    the values fit a replay block is left to the block's own checks.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "manifest.json"
    manifest = read_json(path, "manifest")
    where = f"manifest {path}"
    _need(isinstance(manifest, dict), where, "is not a JSON object")
    windmills = manifest.get("windmills")
    _need(isinstance(windmills, list) and windmills, where, "has no 'windmills' list")
    names = {}
    # rast-manifest/2 and later carry every stream's CRC-32: one without it was edited
    with_crc = isinstance(manifest.get("format"), str) and manifest["format"].startswith("rast-manifest/") \
        and manifest["format"] != "rast-manifest/1"
    for k, w in enumerate(windmills):
        at = f"{where}: windmills[{k}]"
        _need(isinstance(w, dict), at, "is not an object")
        for key, kind in (("name", str), ("hex_file", str)):
            _need(isinstance(w.get(key), kind), at, f"lacks the text '{key}'")
        _need(_is_int(w.get("length")) and w["length"] >= 1, at, "lacks a positive integer 'length'")
        _need("crc32" in w or not with_crc, at, f"lacks its 'crc32', which every {manifest.get('format')} "
              "stream carries: the manifest was edited; run 'rast stream' again")
        _need("crc32" not in w or (_is_int(w["crc32"]) and 0 <= w["crc32"] <= 0xFFFFFFFF), at,
              f"has a 'crc32' that is not a 32-bit unsigned integer: {w.get('crc32')!r}")
        names[w["name"]] = w
    registers = manifest.get("registers")
    channels = registers.get("channels") if isinstance(registers, dict) else None
    _need(isinstance(channels, list) and channels, where, "has no 'registers.channels' list")
    for k, ch in enumerate(channels):
        at = f"{where}: registers.channels[{k}]"
        _need(isinstance(ch, dict), at, "is not an object")
        _need(isinstance(ch.get("windmill"), str) and ch["windmill"] in names, at,
              f"names windmill {ch.get('windmill')!r}, which 'windmills' does not list")
        _need("delay_samples" in ch or "delay_increment" not in ch, at,
              "has a 'delay_increment' (a manifest of chained delays, from an older rast): "
              "run 'rast stream' again")
        for key in ("length", "phase_increment", "gain", "delay_samples"):
            _need(_is_int(ch.get(key)), at, f"lacks the integer '{key}'")
        _need(ch.get("enable", 1) in (0, 1) and not isinstance(ch.get("enable"), (bool, float)), at,
              "'enable' must be 0 or 1")
        _need(ch["length"] == names[ch["windmill"]]["length"], at,
              f"length {ch['length']} differs from windmill {ch['windmill']!r}'s "
              f"{names[ch['windmill']]['length']}")
    return manifest, path


def manifest_streams(manifest: dict, folder) -> list[list[int]]:
    """The stream words of each channel of ``manifest`` (in channel order), read
    from the ``.hex`` files in ``folder``; every problem names the file and line."""
    by_name = {w["name"]: w for w in manifest["windmills"]}
    streams = []
    for ch in manifest["registers"]["channels"]:
        path = Path(folder) / by_name[ch["windmill"]]["hex_file"]
        try:
            lines = path.read_text(encoding="ascii").split("\n")
        except OSError as error:
            raise UserError(f"cannot read the stream file {path}: {error.strerror or error}") from None
        except UnicodeDecodeError:
            raise UserError(f"the stream file {path} is not a text file of hex words") from None
        words = []
        for number, line in enumerate(lines, 1):
            text = line.strip()
            if not text:
                continue
            if not _HEX_WORD.fullmatch(text):
                raise UserError(f"{path}: line {number}: {text[:20]!r} is not a 32-bit hex word")
            words.append(int(text, 16))
        if len(words) != ch["length"]:
            raise UserError(f"{path} has {len(words)} words, the manifest says {ch['length']}")
        want = by_name[ch["windmill"]].get("crc32")       # manifests before the CRC have none
        got = stream_crc32(words) if want is not None else None
        if got != want:
            raise UserError(f"{path} has CRC-32 {got:#010x}, the manifest says "
                            f"{int(want):#010x}: the file changed after `rast stream` wrote it")
        streams.append(words)
    return streams


def check_output(path, *, folder: bool, option: str) -> Path:
    """Refuse an output ``path`` that cannot be created, before anything is written.

    ``folder``: the output is a folder (it may exist) rather than a file (it
    may exist as a regular file, and is replaced; a device, FIFO or folder in
    its place is refused: ``rast.model.files.outputs``). ``option`` names the argument.
    """
    from rast.model.files.outputs import OutputError, check_target
    if not str(path).strip():
        raise UserError(f"{option} is empty: give a {'folder' if folder else 'file'} name")
    path = Path(path)
    if path.exists() or path.is_symlink():
        if folder and not path.is_dir():
            raise UserError(f"{option} {path} exists and is not a folder")
        if not folder:
            if path.is_dir():
                raise UserError(f"{option} {path} is a folder, not a file")
            try:
                check_target(path)
            except OutputError as error:
                raise UserError(f"{option} {error}") from None
    parent = path if folder else path.parent
    ancestor = parent
    while not ancestor.exists():
        if ancestor.is_symlink():
            raise UserError(f"{option} {path}: {ancestor} is a broken link")
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise UserError(f"{option} {path}: {ancestor} is a file, not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise UserError(f"{option} {path}: cannot write into {ancestor}")
    return path


def positive_hz(text: str) -> float:
    """argparse type of a frequency option (``--zoom``): a positive number of Hz."""
    import argparse
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive frequency in Hz, not {text}")
    return value
