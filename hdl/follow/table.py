"""The turbine table: rows of four 32-bit words in block RAM, written by the
host a word at a time, read by the assigner (a row's azimuth) and the loader
(a whole row) (``rast.model.contract.follow``: FOLLOW_ROW_FIELDS)."""

from amaranth.hdl import Module, Cat
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from rast.model.contract.follow import FOLLOW_ROW_WORDS
from rast.model.contract.scan import AZIMUTH_BITS

__all__ = ["TurbineTable"]


class TurbineTable(wiring.Component):
    """``rows`` rows, each word a lane of its own RAM (so the loader reads a
    row in one clock), and the rows' azimuths once more in a RAM of their
    own (the assigner's port; block RAMs have two). Reads take a clock.

    Members
    -------
    w_en : In(1), w_addr : In(range(4 · rows)), w_data : In(32)
        A word: row ``w_addr // 4``, word ``w_addr % 4``.
    az_addr : In(range(rows)), az_data : Out(16)
    row_addr : In(range(rows)), row_data : Out(128)
    """

    def __init__(self, rows: int):
        if not isinstance(rows, int) or isinstance(rows, bool) or rows < 1:
            raise ValueError(f"rows must be a positive integer, not {rows!r}")
        self._rows = rows
        super().__init__({
            "w_en": In(1), "w_addr": In(range(FOLLOW_ROW_WORDS * rows)), "w_data": In(32),
            "az_addr": In(range(rows)), "az_data": Out(AZIMUTH_BITS),
            "row_addr": In(range(rows)), "row_data": Out(32 * FOLLOW_ROW_WORDS),
        })

    def elaborate(self, platform):
        m = Module()
        lane, row = self.w_addr[:2], self.w_addr[2:]
        words = []
        for k in range(FOLLOW_ROW_WORDS):
            m.submodules[f"lane{k}"] = ram = Memory(shape=32, depth=self._rows, init=[])
            w, r = ram.write_port(), ram.read_port()
            m.d.comb += [w.addr.eq(row), w.data.eq(self.w_data), w.en.eq(self.w_en & (lane == k)),
                         r.addr.eq(self.row_addr)]
            words.append(r.data)
        m.submodules.azimuths = az = Memory(shape=AZIMUTH_BITS, depth=self._rows, init=[])
        w, r = az.write_port(), az.read_port()
        m.d.comb += [w.addr.eq(row), w.data.eq(self.w_data[:AZIMUTH_BITS]), w.en.eq(self.w_en & (lane == 0)),
                     r.addr.eq(self.az_addr), self.az_data.eq(r.data), self.row_data.eq(Cat(*words))]
        return m
