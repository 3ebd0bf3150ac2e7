"""A pipeline's copy of the delay window: the common line's output written
once per step, read at each visiting slot's tap."""

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import ReplayContract, INPUT_WIDTH, WINDOW_LAG, WORD_CYCLES, visit_cycles
from ..delay_line import DelayLine
from ..ecp5_primitives import kept_register
from ..register_chain import delayed
from .schedule import accept_clock

__all__ = ["WindowTap", "COMMON_OUT_CYCLES"]

#: Clocks from the period start to the common line's c[n] on ``win_data``
#: (the top asks the line's read for step n in the clock before the period
#: start and registers the line's word once, beside its block RAMs, for all
#: pipelines).
COMMON_OUT_CYCLES = 4


class WindowTap(wiring.Component):
    """The window of one pipeline: t[n] = c[n - 1 - DELAY] for each visiting slot.

    A slot's tap is read WORD_CYCLES - latency - 1 clocks after its visit
    and its sample registered in fabric (the complex multiplier's operand
    registers), so that it is out with the word: the RAM's output
    register went straight into the multipliers' input
    registers, the latest path of a two-pipeline build (7.9 ns, 6.9 of
    it routing, docs/bitstream.md). c[n] comes from the common line
    COMMON_OUT_CYCLES after the period start and reaches the RAM just
    after the last read of the step before (a write for step n + 1 never
    meets a read for step n at the RAM: tests/formal/replay_formal.py's
    rule).
    Each of the window's block RAMs has its write and read-address
    registers of its own (the line's groups), so the write is handed to
    the line a clock before it reaches the RAM. The read address is
    registered once, then copied for each block RAM (its adder straight
    into the four copies was late in 16- and 64-channel builds,
    5.3 ns), so the read is handed to the line a clock earlier and
    reaches the RAM in the same clock as without the copies.

    Parameters
    ----------
    contract : ReplayContract
    sites : sequence of str or None
        On ECP5 the block-RAM sites of the window's block RAMs, or None.
    win_data_lag : int
        Registers of c[n]'s way the top provides (at most :meth:`win_data_room`).

    Members
    -------
    win_data : In(32)
        c[n], COMMON_OUT_CYCLES after the period start.
    write : In(1)
        The period's step is accepted (the pipeline's clock ``accept_clock``).
    held_index : In
        The step's number, from the clock after ``write``.
    step_index, tap : In
        At the visit: the step's number and the slot's tap (DELAY).
    o : Out(32)
        The tap's sample, WORD_CYCLES - 1 clocks after the visit (the value
        the complex multiplier's operand registers take).
    """

    def __init__(self, contract, *, sites=None, win_data_lag=0):
        if not isinstance(contract, ReplayContract):
            raise TypeError(f"Contract must be a ReplayContract, not {contract!r}")
        M = contract.slots
        room = self.win_data_room(M)
        if not isinstance(win_data_lag, int) or isinstance(win_data_lag, bool) or not 0 <= win_data_lag <= room:
            raise ValueError(f"Window data lag must be an integer in [0, {room}] at {M} slots, "
                             f"not {win_data_lag!r}")
        self._c, self._sites, self._win_data_lag = contract, sites, win_data_lag
        W = contract.window_depth
        tap_bits = max(1, contract.max_tap.bit_length())
        super().__init__({"win_data": In(2 * INPUT_WIDTH), "write": In(1), "held_index": In(range(W)),
                          "step_index": In(range(W)), "tap": In(tap_bits), "o": Out(2 * INPUT_WIDTH)})

    @staticmethod
    def window_write_cycles(slots: int) -> int:
        """Clocks from the period start to the window's write at its RAM: after
        the visit and the tap's read at the RAM (WORD_CYCLES - the latency of
        a line without address copies - 1 after it); from M = 4 up to two
        clocks later, well before step n + 1 reads c[n] at tap 0
        (test_every_delay_echo_position fails with the write M clocks later),
        so that c[n] passes more registers on its way from the common line."""
        read_at = WORD_CYCLES - DelayLine.LATENCY - 1
        return visit_cycles(slots) + read_at + 1 + min(2, max(0, slots - 3))

    @classmethod
    def win_data_room(cls, slots: int) -> int:
        """Registers c[n] passes between ``win_data`` (COMMON_OUT_CYCLES after
        the period start) and the window's write registers: the top may
        take up to this many of them (``win_data_lag``)."""
        return cls.window_write_cycles(slots) - 1 - COMMON_OUT_CYCLES

    def elaborate(self, platform):
        m = Module()
        c = self._c
        M, A = c.slots, accept_clock(c.slots)
        win_bits = DelayLine.slice_bits(2 * INPUT_WIDTH, c.max_tap, WINDOW_LAG)
        m.submodules.line = win = DelayLine(
            2 * INPUT_WIDTH, c.max_tap, WINDOW_LAG, group_bits=win_bits, sites=self._sites,
            address_copies=-(-2 * INPUT_WIDTH // win_bits))
        assert win.depth == c.window_depth and win.latency == DelayLine.LATENCY + 1
        read_at = WORD_CYCLES - win.latency - 1
        write_at = self.window_write_cycles(M)
        wen = delayed(m, self.write, write_at - 1 - A, "win_wen")
        # c[n] through registers of the pipeline's own (kept): every pipeline
        # delays the same common-line word, so plain registers were one chain
        # to Yosys, feeding all the windows' write registers across the device
        # (6.2-6.7 ns at 64 channels); win_data_lag of them are the top's
        wdata = self.win_data
        for k in range(self.win_data_room(M) - self._win_data_lag):
            wdata = kept_register(m, platform, wdata, f"win_wdata_d{k + 1}")
        windex = delayed(m, self.held_index, write_at - 2 - A, "win_windex", data=True)
        m.d.comb += [win.w_en.eq(wen), win.w_index.eq(windex), win.w_data.eq(wdata),
                     win.r_index.eq(delayed(m, self.step_index, read_at, "win_rindex", data=True)),
                     win.r_delay.eq(delayed(m, self.tap, read_at, "win_rdelay", data=True)),
                     self.o.eq(win.o)]
        return m
