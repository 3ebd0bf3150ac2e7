"""The turbine table: rows of four 32-bit words in block RAM, written by the
host a word at a time, read by the assigner (a row's azimuth) and the loader
(a whole row) (``rast.model.contract.follow``: FOLLOW_ROW_FIELDS)."""

from amaranth.hdl import Module, Cat
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.follow import FOLLOW_ROW_WORDS
from rast.model.contract.scan import AZIMUTH_BITS
from ..ecp5_primitives import RegisteredRAM

__all__ = ["TurbineTable"]


class TurbineTable(wiring.Component):
    """``rows`` rows, each word a lane of its own RAM (so the loader reads a
    row at once), and the rows' azimuths once more in a RAM of their own (the
    assigner's port; block RAMs have two). Reads take ``latency`` clocks: the
    block RAM's own output register (its output straight into the
    assigner's sums was 15.4 ns, the first following build's latest path).

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

    #: Clocks from an address to its word.
    latency = 2

    def elaborate(self, platform):
        m = Module()
        lane, row = self.w_addr[:2], self.w_addr[2:]
        depth = max(2, self._rows)
        words = []
        for k in range(FOLLOW_ROW_WORDS):
            m.submodules[f"lane{k}"] = ram = RegisteredRAM(32, depth, continuous=True, output_reset=False)
            m.d.comb += [ram.w_addr.eq(row), ram.w_data.eq(self.w_data), ram.w_en.eq(self.w_en & (lane == k)),
                         ram.r_addr.eq(self.row_addr)]
            words.append(ram.r_data)
        m.submodules.azimuths = az = RegisteredRAM(AZIMUTH_BITS, depth, continuous=True, output_reset=False)
        m.d.comb += [az.w_addr.eq(row), az.w_data.eq(self.w_data[:AZIMUTH_BITS]), az.w_en.eq(self.w_en & (lane == 0)),
                     az.r_addr.eq(self.az_addr), self.az_data.eq(az.r_data), self.row_data.eq(Cat(*words))]
        assert az.latency == self.latency
        return m
