"""A RAM delay line indexed by step: written once per step, read at any tap."""

from amaranth.hdl import Module, Signal, Cat, Const, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .ecp5_primitives import RegisteredRAM, kept_register, dp16kd_mode
from rast.model.contract.fixedpoint import delay_depth

__all__ = ["DelayLine"]


class DelayLine(wiring.Component):
    """Step-indexed delay line: the word of step k is written at address
    ``k mod depth``; a read for step n at delay d returns the word of step
    ``n - lag - d`` (``o``, ``latency`` clocks after ``r_index``/``r_delay``).

    One block RAM of ``depth`` words (the power of two >= ``max_delay + 2``)
    with a registered read address and a registered output. The engine's
    common line reads once per step, each pipeline's window once per slot;
    the caller keeps the step count and writes each step's word before any
    read that needs it (``rast.hdl.replay_top``). With ``lag`` >= 1 a read
    never addresses the word written in the same clock: the read for step n
    at delay ``max_delay`` addresses ``n - lag - max_delay``, which step ``n +
    1`` overwrites only after ``depth >= max_delay + lag + 1`` steps.
    Words never written read as zero.

    With ``group_bits`` the RAM is split into groups of that many bits, each
    with registers of its own for the write (enable, index, its part of the
    word) and for the read address, kept apart in synthesis
    (:func:`kept_register`) so that each may sit beside its group: a line
    whose block RAMs are spread over the device is then not fed from one
    register. A write is then presented a clock before it reaches the RAM
    (the caller gives ``w_*`` a clock earlier than without groups); the
    read's latency is the same.

    With ``address_copies`` (groups only) the read address is registered
    once, then copied into ``address_copies`` kept registers, each feeding
    its share of the groups' RAMs directly (with ``sites`` given row by
    row, one copy per row, beside the row's block of RAMs): the read is then
    presented a clock earlier, so ``latency`` is 4, and the logic that makes
    the address ends at one register, not at registers beside every RAM.
    The address's subtraction feeding registers in all of the device's four
    rows was a latest path of the two-pipeline build (docs/bitstream.md).

    Parameters
    ----------
    width : int
        Bits per word.
    max_delay : int
        Largest delay.
    lag : int
        Steps between a word and its read at delay 0 (the contract's
        COMMON_LAG / WINDOW_LAG).
    group_bits : int or None
        Bits per group of block RAMs with registers of its own (above).
    sites : sequence of str or None
        With groups on ECP5: a block-RAM site (nextpnr bel) for each group,
        each then one block RAM (as ``slice_bits`` makes them), so that they
        lie together rather than wherever the placer finds room.
    address_copies : int or None
        With groups: copies of the registered read address, instead of a
        register per group (above); the read is presented a clock earlier.

    Members
    -------
    w_en : In(1), w_index : In(range(depth)), w_data : In(width)
        Write the word of step ``w_index``.
    r_index : In(range(depth)), r_delay : In(range(max_delay + 1))
        Read for step ``r_index`` at delay ``r_delay`` (values above
        ``max_delay`` must not be given).
    o : Out(width)
    """

    def __init__(self, width, max_delay, lag=1, *, group_bits=None, sites=None, address_copies=None):
        if not isinstance(width, int) or isinstance(width, bool) or width <= 0:
            raise TypeError(f"Delay line width must be a positive integer, not {width!r}")
        if not isinstance(max_delay, int) or isinstance(max_delay, bool) or max_delay < 0:
            raise TypeError(f"Maximum delay must be a non-negative integer, not {max_delay!r}")
        if not isinstance(lag, int) or isinstance(lag, bool) or lag < 1:
            raise ValueError(f"Lag must be a positive integer, not {lag!r}")
        if group_bits is not None and (not isinstance(group_bits, int) or isinstance(group_bits, bool)
                                       or not 0 < group_bits <= width):
            raise ValueError(f"Group bits must be None or an integer in [1, {width}], not {group_bits!r}")
        self._group_bits = group_bits
        groups = 0 if group_bits is None else -(-width // group_bits)
        if sites is not None and (len(sites := tuple(sites)) != groups or groups == 0
                                  or not all(isinstance(x, str) for x in sites)):
            raise ValueError(f"Sites must be None or, with groups of block RAMs, {groups or 'no'} bel "
                             f"names, not {sites!r}")
        self._sites = sites
        if address_copies is not None:
            if not groups:
                raise ValueError(f"Address copies must be None without groups of block RAMs, "
                                 f"not {address_copies!r}")
            if not isinstance(address_copies, int) or isinstance(address_copies, bool) \
                    or not 0 < address_copies <= groups:
                raise ValueError(f"Address copies must be None or, with groups of block RAMs, an integer "
                                 f"in [1, {groups}], not {address_copies!r}")
        self._address_copies = address_copies
        self._width = width
        self._max_delay = max_delay
        self._lag = lag
        self._depth = delay_depth(max_delay + lag - 1)
        super().__init__({
            "w_en": In(1),
            "w_index": In(range(self._depth)),
            "w_data": In(unsigned(width)),
            "r_index": In(range(self._depth)),
            "r_delay": In(range(max_delay + 1)),
            "o": Out(unsigned(width)),
        })

    @staticmethod
    def slice_bits(width, max_delay, lag=1):
        """Bits per block RAM of a line of this shape on ECP5 (``width`` when
        it is deeper than a DP16KD): the ``group_bits`` that gives every block
        RAM registers of its own."""
        mode = dp16kd_mode(width, delay_depth(max_delay + lag - 1))
        return min(mode[0], width) if mode else width

    #: Clocks from a read's ``r_index``/``r_delay`` to its word on ``o``
    #: without address copies (one more with them).
    LATENCY = 3

    @property
    def latency(self):
        """Clocks from a read's ``r_index``/``r_delay`` to its word on ``o``."""
        return self.LATENCY + (self._address_copies is not None)

    @property
    def width(self):
        return self._width

    @property
    def max_delay(self):
        return self._max_delay

    @property
    def depth(self):
        return self._depth

    def elaborate(self, platform):
        m = Module()
        if self._group_bits is not None:
            return self._elaborate_groups(m, platform)
        # Block RAM with its output register (DP16KD OUTREG on ECP5), the read
        # address from a register beside it.
        m.submodules.mem = mem = RegisteredRAM(self._width, self._depth, addr_reg=True)
        assert mem.latency == self.latency
        m.d.comb += [mem.w_en.eq(self.w_en), mem.w_addr.eq(self.w_index), mem.w_data.eq(self.w_data),
                     mem.r_en.eq(1), mem.r_addr.eq(self._read_address()),
                     self.o.eq(mem.r_data)]
        return m

    def _read_address(self):
        """``r_index - lag - r_delay`` modulo the depth. At the lines' lag of 1
        written as the true subtraction ``(2 r_index - (2 r_delay + 1)) >> 1``:
        one carry chain whose cells take the subtrahend inverted (Yosys's ECP5
        carry mapping), where ``r_index + ~r_delay`` put an inverter LUT in
        front of every bit, and two chains in a row were among a 64-channel
        build's late paths (5.3 ns)."""
        bits = len(self.r_index)
        delay = Cat(self.r_delay, Const(0, bits - len(self.r_delay)))
        total = (Cat(Const(0, 1), self.r_index) - Cat(Const(1, 1), delay))[1:bits + 1]
        offset = (1 - self._lag) % self._depth
        return (total + offset)[:bits] if offset else total

    def _elaborate_groups(self, m, platform):
        r_addr = Signal(range(self._depth))
        m.d.comb += r_addr.eq(self._read_address())
        groups = -(-self._width // self._group_bits)
        if self._address_copies is None:       # a register per group
            addrs = [kept_register(m, platform, r_addr, f"mem_bits{g}_r_addr")
                     for g in range(0, self._width, self._group_bits)]
        else:                                  # one register, then its copies
            r_q = kept_register(m, platform, r_addr, "r_addr")
            copies = [kept_register(m, platform, r_q, f"r_addr_copy{k}") for k in range(self._address_copies)]
            addrs = [copies[k * len(copies) // groups] for k in range(groups)]
        words = []
        for k, g in enumerate(range(0, self._width, self._group_bits)):
            gw = min(self._group_bits, self._width - g)
            name = f"mem_bits{g}"
            m.submodules[name] = mem = RegisteredRAM(gw, self._depth, continuous=True, output_reset=False,
                                                     sites=self._sites and (self._sites[k],))
            assert 1 + (self._address_copies is not None) + mem.latency == self.latency
            m.d.comb += [mem.w_en.eq(kept_register(m, platform, self.w_en, f"{name}_w_en", reset=True)),
                         mem.w_addr.eq(kept_register(m, platform, self.w_index, f"{name}_w_index")),
                         mem.w_data.eq(kept_register(m, platform, self.w_data[g:g + gw], f"{name}_w_data")),
                         mem.r_addr.eq(addrs[k])]
            words.append(mem.r_data)
        m.d.comb += self.o.eq(Cat(*words))
        return m
