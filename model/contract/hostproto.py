"""The UART host protocol of the replay bridge, host side, in plain Python.

The same code talks to a board (``rast load``, through pyserial) and to the
bridge in the Amaranth simulator (``tests/test_load_bridge.py``): a
:class:`HostBridge` needs only a transport with ``write(bytes)`` and
``read(n) -> bytes`` (pyserial's ``Serial`` is one).

Frames, host to device (8N1, all multi-byte fields little-endian):

=========  ==========================================  ======================
command    bytes that follow                           reply
=========  ==========================================  ======================
``W`` 57h  addr (2), data (4)                          ``K`` (4Bh) after the write
``B`` 42h  addr (2), count n (2), n x data (4)         ``K`` after the n-th write
``R`` 52h  addr (2)                                    data (4)
``V`` 56h  (none)                                      ``BRIDGE_ID`` (4)
=========  ==========================================  ======================

``B`` writes ``n`` words to the same address: the stream RAM's STREAM_DATA
register advances its own address, so a whole stream is one frame. Any other
command byte is ignored. A frame interrupted for longer than the bridge's
timeout (a build parameter, 20 ms by default) is dropped, so a host that was
cut off mid-frame resynchronises by staying silent for longer than that
(:meth:`HostBridge.resync`). Replies come back in command order; the bridge
queues up to ``TX_FIFO_DEPTH`` reply bytes, so a host may pipeline writes
freely (one ``K`` per frame of at least 7 bytes) but waits for each read.
"""

import struct
import time

__all__ = ["CMD_WRITE", "CMD_BURST", "CMD_READ", "CMD_VERSION", "ACK", "BRIDGE_ID",
           "PROTOCOL_VERSION", "TX_FIFO_DEPTH", "MAX_BURST", "DEFAULT_BAUD", "line_bytes", "line_seconds", "ProtocolError",
           "HostBridge", "encode_write", "encode_burst", "encode_read", "group_writes"]

CMD_WRITE = 0x57    # "W"
CMD_BURST = 0x42    # "B"
CMD_READ = 0x52     # "R"
CMD_VERSION = 0x56  # "V"
ACK = 0x4B          # "K"
PROTOCOL_VERSION = 1
BRIDGE_ID = 0x42520000 | PROTOCOL_VERSION   # "BR", version
TX_FIFO_DEPTH = 16
MAX_BURST = 0xFFFF
ADDR_LIMIT = 1 << 16
#: The line rate of a default build and of ``rast load``: the ULX3S's FT231X
#: makes 3 Mbaud exactly (its 3 MHz baud clock, divisor 1), the fastest it has.
DEFAULT_BAUD = 3_000_000


class ProtocolError(Exception):
    """The device answered something other than what the protocol says."""


def _check(addr, value=0):
    if not isinstance(addr, int) or not 0 <= addr < ADDR_LIMIT:
        raise ValueError(f"Register address must be an integer in [0, 0xffff], not {addr!r}")
    if not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
        raise ValueError(f"Register value must be an integer in [0, 0xffffffff], not {value!r}")


def encode_write(addr: int, value: int) -> bytes:
    _check(addr, value)
    return struct.pack("<BHI", CMD_WRITE, addr, value)


def encode_burst(addr: int, values) -> bytes:
    values = [int(v) for v in values]
    if not 1 <= len(values) <= MAX_BURST:
        raise ValueError(f"A burst carries 1 to {MAX_BURST} words, not {len(values)}")
    for v in values:
        _check(addr, v)
    return struct.pack(f"<BHH{len(values)}I", CMD_BURST, addr, len(values), *values)


def encode_read(addr: int) -> bytes:
    _check(addr)
    return struct.pack("<BH", CMD_READ, addr)


def group_writes(writes):
    """Turn ``[(addr, value), ...]`` into frames: runs of writes to one address
    (a stream) become bursts, the rest single writes. Order is kept."""
    frames = []
    i = 0
    writes = list(writes)
    while i < len(writes):
        addr = writes[i][0]
        j = i
        while j < len(writes) and writes[j][0] == addr and j - i < MAX_BURST:
            j += 1
        if j - i > 1:
            frames.append(encode_burst(addr, [v for _, v in writes[i:j]]))
        else:
            frames.append(encode_write(addr, writes[i][1]))
        i = j
    return frames


def line_bytes(writes) -> int:
    """Bytes of the frames of ``writes`` (:func:`group_writes`), host to board."""
    return sum(len(f) for f in group_writes(writes))


def line_seconds(writes, baud: int = DEFAULT_BAUD) -> float:
    """Time the frames of ``writes`` take on the line at ``baud``, 10 bits a
    byte (8N1), host to board; the replies travel the other way at the same time."""
    return line_bytes(writes) * 10 / baud


class HostBridge:
    """Register access through the UART bridge.

    Parameters
    ----------
    transport
        An object with ``write(bytes)`` and ``read(n) -> bytes`` (``read``
        may return fewer bytes on a timeout, as pyserial does).
    window : int
        Frames sent before their acknowledgements are collected (kept below
        the bridge's reply queue).
    """

    def __init__(self, transport, window=8):
        if not 1 <= window <= TX_FIFO_DEPTH:
            raise ValueError(f"Window must be in [1, {TX_FIFO_DEPTH}], not {window!r}")
        self.transport = transport
        self.window = window
        self._unacked = 0

    def _read_exact(self, n, what):
        data = self.transport.read(n)
        if len(data) != n:
            raise ProtocolError(f"Timed out waiting for {what}: got {len(data)} of {n} bytes "
                                f"({bytes(data).hex() or 'nothing'})")
        return bytes(data)

    def _collect_acks(self, keep=0):
        while self._unacked > keep:
            n = self._unacked - keep
            got = self._read_exact(n, f"{n} acknowledgement(s)")
            if any(b != ACK for b in got):
                raise ProtocolError(f"Expected acknowledgements {ACK:#04x}, got {got.hex()}")
            self._unacked -= n

    def _send_frame(self, frame):
        self.transport.write(frame)
        self._unacked += 1
        if self._unacked >= self.window:
            self._collect_acks(keep=self.window // 2)

    def flush(self):
        """Wait until every frame sent has been acknowledged."""
        self._collect_acks()

    def write(self, addr, value):
        self._send_frame(encode_write(addr, value))

    def burst(self, addr, values):
        for k in range(0, len(values), MAX_BURST):
            self._send_frame(encode_burst(addr, values[k:k + MAX_BURST]))

    def write_many(self, writes, progress=None):
        """Send ``[(addr, value), ...]`` (runs to one address as bursts); ``progress(done, total)``
        is called with the number of writes sent."""
        frames = group_writes(writes)
        total, done = len(writes), 0
        for f in frames:
            self._send_frame(f)
            done += 1 if f[0] == CMD_WRITE else struct.unpack_from("<H", f, 3)[0]
            if progress:
                progress(done, total)
        self.flush()

    def read(self, addr):
        self.flush()
        self.transport.write(encode_read(addr))
        return struct.unpack("<I", self._read_exact(4, f"the value of register {addr:#x}"))[0]

    def version(self):
        """The bridge's identification word, ``BRIDGE_ID`` for this protocol."""
        self.flush()
        self.transport.write(bytes([CMD_VERSION]))
        return struct.unpack("<I", self._read_exact(4, "the bridge version"))[0]

    def resync(self, quiet_s=0.05, drain=None):
        """Stay silent longer than the bridge timeout, then discard stale replies
        (``drain``, default the transport's ``reset_input_buffer`` if it has one)."""
        time.sleep(quiet_s)
        drain = drain or getattr(self.transport, "reset_input_buffer", None)
        if drain is not None:
            drain()
        self._unacked = 0
