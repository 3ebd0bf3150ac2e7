"""A pipeline's pattern gain: the channel's gain times the antenna's
two-way pattern at the beam's offset from the channel's azimuth (the
contract's rule, ``rast.model.contract.scan``; docs/antenna_scan.md)."""

from amaranth.hdl import Cat, Module, Signal, Mux
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import GAIN_WIDTH
from rast.model.contract.scan import (AZIMUTH_BITS, PATTERN_INDEX_BITS, PATTERN_ENTRIES, PATTERN_WIDTH,
                                      PATTERN_FRAC, PATTERN_ONE, MAX_PATTERN_SHIFT)
from ..ecp5_primitives import RegisteredMultiplier, RegisteredRAM
from ..register_chain import delayed

__all__ = ["PatternGain", "BEAM_LAYOUT", "PATTERN_LAYOUT", "BEAM_CLOCK", "GAIN_INPUT_DELAY"]

#: A step's beam as the top hands it to each pipeline: its code, and whether
#: the scan plays (SCAN_CTRL.mode not stare), both taken when the generator
#: takes the step.
BEAM_LAYOUT = data.StructLayout({"code": AZIMUTH_BITS, "on": 1})
#: The pattern's settings and the table's write, from the register file.
PATTERN_LAYOUT = data.StructLayout({"shift": 3, "floor": PATTERN_WIDTH, "w_en": 1,
                                    "w_addr": PATTERN_INDEX_BITS, "w_data": PATTERN_WIDTH})
#: The clock of a pipeline's period from which its ``beam`` holds the step's
#: beam, for M clocks: the generator takes the step in the period's first
#: clock, into a register, then a copy per pipeline.
BEAM_CLOCK = 2
#: Clocks from a visit to the pattern gain's gain and azimuth inputs (a
#: register each): the beam, BEAM_CLOCK clocks into the period, reaches the
#: first visit's pattern gain at every M (the visit is 1 or 2 clocks into
#: it, ``visit_cycles``).
GAIN_INPUT_DELAY = 1


class PatternGain(wiring.Component):
    """``round_half_up(gain · word, 15)``, ``word`` the pattern table's entry
    for ``beam − azimuth`` (the floor word beyond the table's span; 2**15,
    0 dB, when ``scan`` is off), :attr:`latency` clocks after its inputs.

    The contract's index ``(o + h) >> shift``, ``h = 2**(9 + shift)``, needs no
    adder: ``h`` has one bit set, so the sum is the signed offset ``o`` with
    bit ``9 + shift`` inverted, and it lies in the table's span ``[0, 2h)``
    exactly where ``o``'s bits from ``9 + shift`` up are all equal (``o``
    fits in ``10 + shift`` signed bits).

    The stages: the offset; the table's index and whether the offset lies in
    its span (``shift`` 0..6); the table's read (one block RAM and its own
    output register, its write port from the register file); the word in a
    fabric register; the word or the floor; the product (one MULT18X18D
    with input and output registers); the product in a fabric register; the
    rounding. (The block RAM's read without its output register, and the
    floor's choice, in one clock were the scan build's latest path at seed
    2: 10.6 ns, 94.7 MHz; the offset's add of the half-span and the span's
    check in one clock at seed 1 of ``0f00145``, 6.7 ns, 148.4 MHz; the
    block RAM's output register into the
    floor's choice at seeds 4 and 5 of ``c424cbb``, 6.2 ns of one route,
    132.6 MHz; the multiplier's output register into the rounding's adder at
    seeds 4 and 5 of ``d0c1f55``, 6.9 ns, 4.6 of it one route, 145.9 MHz.
    ``latency`` + GAIN_INPUT_DELAY is the product stage's ``max_gain_lag``
    at the four-multiplier product, 11 clocks.)

    Parameters
    ----------
    site : str or None
        On ECP5, the block-RAM site of the table (a nextpnr bel name), or
        ``None`` to leave it to the placer.

    Members
    -------
    gain : In(GAIN_WIDTH), azimuth : In(AZIMUTH_BITS), beam : In(AZIMUTH_BITS)
        The visiting channel's gain and azimuth, the step's beam.
    scan : In(1), shift : In(3), floor : In(PATTERN_WIDTH)
        The scan's settings (held while the scan plays).
    w_en, w_addr, w_data : In
        A table entry written.
    o : Out(GAIN_WIDTH)
    """

    latency = 10

    def __init__(self, *, site=None):
        if site is not None and not isinstance(site, str):
            raise ValueError(f"Pattern table site must be a bel name or None, not {site!r}")
        self._site = site
        super().__init__({
            "gain": In(GAIN_WIDTH), "azimuth": In(AZIMUTH_BITS), "beam": In(AZIMUTH_BITS),
            "scan": In(1), "shift": In(3), "floor": In(PATTERN_WIDTH),
            "w_en": In(1), "w_addr": In(PATTERN_INDEX_BITS), "w_data": In(PATTERN_WIDTH),
            "o": Out(GAIN_WIDTH),
        })

    def elaborate(self, platform):
        m = Module()
        I = PATTERN_INDEX_BITS
        offset = Signal(AZIMUTH_BITS)
        m.d.sync += offset.eq(self.beam - self.azimuth)                               # 1
        index, inside = Signal(I), Signal()
        shift = delayed(m, self.shift, 1, "shift")
        with m.Switch(shift):                                                         # 2
            for k in range(MAX_PATTERN_SHIFT + 1):
                top = offset[k + I - 1:]                     # the sign and its extension
                with m.Case(k):
                    m.d.sync += [index.eq(Cat(offset[k:k + I - 1], ~offset[k + I - 1])),
                                 inside.eq((top == 0) | (top == (1 << len(top)) - 1))]
            with m.Default():
                m.d.sync += [index.eq(0), inside.eq(0)]
        m.submodules.table = table = RegisteredRAM(PATTERN_WIDTH, PATTERN_ENTRIES, continuous=True,
                                                   output_reset=False,
                                                   sites=None if self._site is None else (self._site,))
        m.d.comb += [table.w_en.eq(self.w_en), table.w_addr.eq(self.w_addr), table.w_data.eq(self.w_data),
                     table.r_addr.eq(index)]                                          # 3, 4: the read
        read = 2 + table.latency             # the clock the table's word is out
        table_word = Signal(PATTERN_WIDTH, name="table_word", reset_less=True)
        m.d.sync += table_word.eq(table.r_data)                                       # 5
        inside_r = delayed(m, inside, table.latency + 1, "inside")
        scan_r, floor_r = delayed(m, self.scan, read + 1, "scan"), delayed(m, self.floor, read + 1, "floor")
        word = Signal(PATTERN_WIDTH + 1)
        m.d.sync += word.eq(Mux(scan_r, Mux(inside_r, table_word, floor_r), PATTERN_ONE))  # 6
        m.submodules.mul = mul = RegisteredMultiplier(GAIN_WIDTH + 1, PATTERN_WIDTH + 1, input_reg=True)
        gain_w = delayed(m, self.gain, read + 2, "gain", data=True)
        m.d.comb += [mul.en.eq(1), mul.a.eq(gain_w), mul.b.eq(word)]                 # 7, 8
        product = delayed(m, mul.o, 1, "product", data=True)                          # 9
        rounded = Signal(GAIN_WIDTH)
        m.d.sync += rounded.eq((product + (1 << (PATTERN_FRAC - 1))) >> PATTERN_FRAC)  # 10
        m.d.comb += self.o.eq(rounded)
        assert read + 2 + mul.latency + 2 == self.latency
        return m
