"""The stream pool: one memory for every channel's stream, read by tagged fetches."""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .ecp5_primitives import RegisteredRAM
from ..model.fixedpoint import STREAM_WIDTH, POOL_BANK_WORDS

__all__ = ["StreamPool"]


class StreamPool(wiring.Component):
    """``words`` stream words in block RAM: a write port for the host and a
    read port for fetches, each carrying a tag that comes back with its word.

    A fetch presented with ``r_valid`` comes back ``latency`` clocks later on
    ``d_valid``/``d_tag``/``d_data`` (every clock may carry one; nothing
    stalls). An address at or beyond ``words`` reads 0 and is not written.
    Pools deeper than POOL_BANK_WORDS are banks of that many words (on ECP5
    each a width-sliced, output-registered RAM) behind a registered
    multiplexer. This is the interface a second back end (external SDRAM)
    serves with a variable latency and ``r_ready``.

    Parameters
    ----------
    words : int
        Pool words: a power of two from 16 to POOL_BANK_WORDS, or a multiple
        of POOL_BANK_WORDS.
    tag_width : int
    init : sequence of int
        Power-up contents from address 0.

    Members
    -------
    w_en : In(1), w_addr : In(address width), w_data : In(32)
    r_valid : In(1), r_addr : In(address width), r_tag : In(tag_width)
    d_valid : Out(1), d_tag : Out(tag_width), d_data : Out(32)
    """

    def __init__(self, words, tag_width, init=()):
        if not (isinstance(words, int) and not isinstance(words, bool) and 16 <= words
                and (words % POOL_BANK_WORDS == 0 if words > POOL_BANK_WORDS else not words & (words - 1))):
            raise ValueError(f"Pool words must be a power of two from 16 to {POOL_BANK_WORDS} or a "
                             f"multiple of {POOL_BANK_WORDS}, not {words!r}")
        if not isinstance(tag_width, int) or isinstance(tag_width, bool) or tag_width < 1:
            raise ValueError(f"Tag width must be a positive integer, not {tag_width!r}")
        init = [int(w) & ((1 << 2 * STREAM_WIDTH) - 1) for w in init]
        if len(init) > words:
            raise ValueError(f"Initial pool contents must have at most {words} words, not {len(init)}")
        self._words, self._init = words, init
        self._bank_words = min(words, POOL_BANK_WORDS)
        self._banks = words // self._bank_words
        aw = (words - 1).bit_length()
        super().__init__({
            "w_en": In(1), "w_addr": In(aw), "w_data": In(2 * STREAM_WIDTH),
            "r_valid": In(1), "r_addr": In(aw), "r_tag": In(tag_width),
            "d_valid": Out(1), "d_tag": Out(tag_width), "d_data": Out(2 * STREAM_WIDTH),
        })

    @property
    def latency(self):
        """Clocks from ``r_valid`` to ``d_valid``: the RAM's 3 (address
        register, read, output register), plus the bank multiplexer's."""
        return 3 + (self._banks > 1)

    def elaborate(self, platform):
        m = Module()
        BW = self._bank_words
        bank_bits = (BW - 1).bit_length()
        rams = []
        for b in range(self._banks):
            ram = RegisteredRAM(2 * STREAM_WIDTH, BW, init=self._init[b * BW:(b + 1) * BW],
                                addr_reg=True)
            m.submodules[f"bank{b}"] = ram
            hit = self.w_addr[bank_bits:] == b
            m.d.comb += [ram.w_en.eq(self.w_en & hit), ram.w_addr.eq(self.w_addr[:bank_bits]),
                         ram.w_data.eq(self.w_data), ram.r_en.eq(1),
                         ram.r_addr.eq(self.r_addr[:bank_bits])]
            rams.append(ram)
        # Valid, tag and bank follow the read through the RAM's three stages.
        L = self.latency
        valid = [self.r_valid] + [Signal(name=f"valid{k}") for k in range(1, L + 1)]
        tag = [self.r_tag] + [Signal.like(self.r_tag, name=f"tag{k}") for k in range(1, L + 1)]
        hi = self.r_addr[bank_bits:]
        bank = [hi] + [Signal(len(hi), name=f"bank{k}") for k in range(1, 4)]
        for k in range(1, L + 1):
            m.d.sync += [valid[k].eq(valid[k - 1]), tag[k].eq(tag[k - 1])]
        if self._banks > 1:
            for k in range(1, 4):
                m.d.sync += bank[k].eq(bank[k - 1])
        if self._banks == 1:
            m.d.comb += self.d_data.eq(rams[0].r_data)
        else:
            with m.Switch(bank[3]):
                for b, ram in enumerate(rams):
                    with m.Case(b):
                        m.d.sync += self.d_data.eq(ram.r_data)
                with m.Default():
                    m.d.sync += self.d_data.eq(0)
        m.d.comb += [self.d_valid.eq(valid[L]), self.d_tag.eq(tag[L])]
        return m
