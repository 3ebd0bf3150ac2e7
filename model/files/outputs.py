"""Output files: each written whole beside its target, then moved over it,
and only ever over a regular file.

Every file a ``rast`` command writes goes through here, so that the rules
hold everywhere:

* a target that exists and is not a regular file (a folder, a character
  device such as ``/dev/null``, a FIFO, a socket) is never replaced:
  :class:`OutputError` names it, before anything is written;
* the file is written under a temporary name in the target's folder and
  moved over the target (``os.replace``) only once it is complete: a full
  disk, a signal or a crash leaves the old file whole and no stray file
  behind.
"""

from __future__ import annotations

import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["OutputError", "check_target", "replace_file", "atomic_file", "write_text", "write_bytes"]


class OutputError(OSError):
    """A target that cannot, or must not, be written."""


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def check_target(path) -> Path:
    """``path`` as a Path, if it may be written: absent, or a regular file (or
    a link to one, which is replaced by the file). Raises :class:`OutputError`."""
    path = Path(path)
    if str(path) in ("", "."):
        raise OutputError(f"{str(path)!r} names no file")
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return path
    except OSError as error:
        raise OutputError(f"{path}: {error.strerror or error}") from None
    if not stat.S_ISREG(mode):
        raise OutputError(f"{path} is {_kind(mode)}: RAST replaces regular files only")
    return path


def replace_file(tmp, target) -> None:
    """Move the complete file ``tmp`` over ``target`` (checked again first);
    ``tmp`` is removed if the move is refused."""
    try:
        check_target(target)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def atomic_file(target, mode: str = "wb", **open_kw):
    """``with atomic_file(path) as f: ...``: ``f`` is a new file beside
    ``path``; when the block ends without an error it is flushed to disk and
    moved over ``path`` (:func:`replace_file`), else removed, the old file
    untouched. The file gets the permissions a plain ``open`` would give."""
    target = check_target(target)
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, mode, **open_kw) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)           # mkstemp made it private
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    replace_file(tmp, target)


def write_text(target, text: str) -> None:
    """``target`` holds ``text`` (UTF-8), written whole or not at all."""
    with atomic_file(target, "w", encoding="utf-8") as f:
        f.write(text)


def write_bytes(target, data: bytes) -> None:
    """``target`` holds ``data``, written whole or not at all."""
    with atomic_file(target, "wb") as f:
        f.write(data)
