"""A simulated board on a pseudo-terminal: ``rast load --port /dev/pts/N``
talks to it as to a ULX3S, and it answers from the bit-exact model.

The bridge is modelled as the gateware's (``rast.gateware.bridge``) parses:
a frame starts at a command byte (``W``, ``B``, ``R``, ``V``; any other byte
outside a frame is ignored), a burst writes each word as it arrives, a
partial frame is dropped after ``timeout_s`` of silence on the line, and
every write is answered with ``K`` once done. Time passes on the board: the
model runs ``samples_per_tick`` samples whenever the line is quiet for a
millisecond, so that switches at a stream's period boundary happen while the
host waits for them.

The line can be made to misbehave once (:class:`Damage`): one bit of one
frame flipped, host to board (the ``index``-th frame the host sends, counted
as the host sent it) or board to host (the ``index``-th reply: an ``K`` or
the 4 bytes of a read or version); or the board stops reading after
``stop_reading_after`` bytes, as one that hangs, so that the host's writes
block.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
import tty
from dataclasses import dataclass

import numpy as np

from rast.model.contract.datapath import ReplayModel
from rast.model.contract.hostproto import ACK, BRIDGE_ID, CMD_BURST, CMD_READ, CMD_VERSION, CMD_WRITE

__all__ = ["Damage", "PtyBoard", "frame_length"]


@dataclass(frozen=True)
class Damage:
    """One bit flipped on the line: ``direction`` "host" (a frame the host
    sends) or "board" (a reply), the ``index``-th of them (from 0), bit
    ``bit`` of it (modulo its length in bits)."""
    direction: str
    index: int
    bit: int


def frame_length(head: bytes) -> int | None:
    """Bytes of the frame ``head`` begins (its command byte first), or None
    while ``head`` is too short to tell (a burst's count); 1 for a byte that
    is no command."""
    cmd = head[0]
    if cmd == CMD_WRITE:
        return 7
    if cmd == CMD_READ:
        return 3
    if cmd == CMD_BURST:
        return None if len(head) < 5 else 5 + 4 * struct.unpack_from("<H", head, 3)[0]
    return 1


class PtyBoard:
    """The board: open it (a context manager), give ``port`` to ``rast load``.

    ``model`` is the board's :class:`ReplayModel` (inspect it after the
    load); ``applied`` lists the register writes it took, in order."""

    def __init__(self, model: ReplayModel, *, damage: Damage | None = None, stop_reading_after=None,
                 samples_per_tick=2000, timeout_s=0.02):
        self.model = model
        self.damage = damage
        self.damaged = False              # the damage happened
        self.stop_reading_after = stop_reading_after
        self.samples_per_tick = samples_per_tick
        self.timeout_s = timeout_s
        self.applied = []
        self._received = 0
        self._host_frames = 0             # frames the host sent, counted on the undamaged stream
        self._pending = bytearray()       # the host's bytes of the frame in progress
        self._forwarded = 0               # of which this many went on to the bridge
        self._replies = 0
        self._frame = bytearray()         # the bridge's frame in progress
        self._last_byte = 0.0
        self._stop = threading.Event()
        self.error = None

    def __enter__(self):
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(timeout=5)
        os.close(self._master)
        os.close(self._slave)
        return False

    # ---- the line ------------------------------------------------------------------
    def _serve(self):
        quiet = np.zeros(self.samples_per_tick, dtype=np.int64)
        try:
            while not self._stop.is_set():
                if self.stop_reading_after is not None and self._received >= self.stop_reading_after:
                    time.sleep(0.01)
                    continue
                ready, _, _ = select.select([self._master], [], [], 0.001)
                if not ready:
                    self.model.run(quiet, quiet)
                    if self._frame and time.monotonic() - self._last_byte > self.timeout_s:
                        self._frame.clear()             # the bridge's timeout drops a partial frame
                    continue
                data = os.read(self._master, 4096)
                if self.stop_reading_after is not None:
                    data = data[:max(0, self.stop_reading_after - self._received)]
                self._received += len(data)
                for b in data:
                    self._from_host(b)
        except Exception as error:           # a bug of the board: the test sees it
            self.error = error
            raise

    def _from_host(self, b: int):
        """One byte as the host sent it: its frames counted, the damaged frame
        held until complete and passed on with its bit flipped, every other
        byte passed on to the bridge at once (a burst's words are taken one
        by one, as the gateware does)."""
        self._pending.append(b)
        n = frame_length(bytes(self._pending[:5]))
        complete = n is not None and len(self._pending) >= n
        target = (self.damage is not None and self.damage.direction == "host"
                  and self._host_frames == self.damage.index)
        if not target:
            for x in self._pending[self._forwarded:]:
                self._to_bridge(x)
            self._forwarded = len(self._pending)
        elif complete:
            frame = bytearray(self._pending)
            frame[self.damage.bit // 8 % len(frame)] ^= 1 << self.damage.bit % 8
            self.damaged = True
            for x in frame:
                self._to_bridge(x)
        if complete:
            self._host_frames += 1
            self._pending, self._forwarded = bytearray(), 0

    def _to_bridge(self, b: int):
        self._last_byte = time.monotonic()
        f = self._frame
        if not f:
            if b in (CMD_WRITE, CMD_BURST, CMD_READ):
                f.append(b)
            elif b == CMD_VERSION:
                self._reply(struct.pack("<I", BRIDGE_ID))
            return                                   # any other byte outside a frame: ignored
        f.append(b)
        cmd = f[0]
        if cmd == CMD_WRITE and len(f) == 7:
            addr, value = struct.unpack_from("<HI", f, 1)
            self._apply(addr, value)
            f.clear()
            self._reply(bytes([ACK]))
        elif cmd == CMD_READ and len(f) == 3:
            addr = struct.unpack_from("<H", f, 1)[0]
            f.clear()
            self._reply(struct.pack("<I", self.model.read(addr) & 0xFFFFFFFF))
        elif cmd == CMD_BURST and len(f) >= 5:
            addr, count = struct.unpack_from("<HH", f, 1)
            if count == 0:
                f.clear()
                self._reply(bytes([ACK]))
            elif (len(f) - 5) % 4 == 0 and len(f) > 5:
                self._apply(addr, struct.unpack_from("<I", f, len(f) - 4)[0])
                if len(f) == 5 + 4 * count:
                    f.clear()
                    self._reply(bytes([ACK]))

    def _apply(self, addr, value):
        self.model.write(addr, value)
        self.applied.append((addr, value))

    def _reply(self, data: bytes):
        data = bytearray(data)
        if self.damage and self.damage.direction == "board" and self._replies == self.damage.index:
            data[self.damage.bit // 8 % len(data)] ^= 1 << self.damage.bit % 8
            self.damaged = True
        self._replies += 1
        os.write(self._master, bytes(data))
