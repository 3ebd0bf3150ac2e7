"""A pipeline's word cache: CACHE_WORDS stream words per slot, filled from
the pool, read by the interpolator at the visiting slot's positions."""

from amaranth.hdl import Module, Signal, Cat, Array, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import STREAM_WIDTH, CACHE_WORDS
from ..ecp5_primitives import kept_register
from ..iq import IQ
from ..register_chain import delayed, select_registered
from .slot_state import POS_BITS, fetch_tag_layout

__all__ = ["WordCache", "CACHE_BANK_BITS"]

#: The word cache in up to 2**k banks, by the slot's upper bits.
CACHE_BANK_BITS = 3


class WordCache(wiring.Component):
    """M x CACHE_WORDS words in distributed RAM, by (slot, position), in up to
    2**CACHE_BANK_BITS banks by the slot's upper bits, so that a read can
    select its bank a clock after the banks' own reads; ``copies`` copies
    (linear interpolation reads two words at once).

    Parameters
    ----------
    slots : int
    readers : list of (name, copy, clocks)
        One read port each: the copy it reads, and ``clocks``: its word in a
        register 1 (hold, linear), 2 or 3 (the FIR's MAC, beside its ROM's
        levels) clocks after its registered address (:meth:`read_latency`).
    copies : int

    Members
    -------
    fill_en : In(1), fill_tag : In(fetch_tag_layout), fill_data : In(32)
        A pool word for a slot's position.
    vslot : In
        The visiting slot.
    read_pos : In(POS_BITS).array(R)
        Each reader's position at the visit.
    read_word : Out(IQ(16)).array(R)
        Each reader's word, ``read_latency(k)`` clocks after the visit.
    read_addr : Out.array(R)
        Each reader's address register (slot, position), a clock after the
        visit: the word it reads (the SDRAM pool's arrival check).
    """

    def __init__(self, slots, readers, copies=1):
        self._slots, self._readers, self._copies = slots, list(readers), copies
        SB = max(1, (slots - 1).bit_length())
        self._depth = CACHE_WORDS << (SB if slots > 1 else 0)
        self._bank_bits = min(CACHE_BANK_BITS, SB if slots > 1 else 0)
        self._in_bank = (self._depth >> self._bank_bits).bit_length() - 1   # address bits inside a bank
        R = len(self._readers)
        super().__init__({
            "fill_en": In(1), "fill_tag": In(fetch_tag_layout(slots)), "fill_data": In(2 * STREAM_WIDTH),
            "vslot": In(range(max(2, slots))),
            "read_pos": In(POS_BITS).array(R), "read_word": Out(IQ(STREAM_WIDTH)).array(R),
            "read_addr": Out(self._in_bank + self._bank_bits).array(R),
        })

    @property
    def depth(self) -> int:
        """Words of the cache: the positions of every slot."""
        return self._depth

    def read_latency(self, k) -> int:
        """Clocks from the visit to reader ``k``'s word in its register."""
        return 1 + self._readers[k][2]

    def elaborate(self, platform):
        m = Module()
        M, SB = self._slots, max(1, (self._slots - 1).bit_length())
        bank_bits, in_bank = self._bank_bits, self._in_bank
        fill_addr = Cat(self.fill_tag.pos, self.fill_tag.slot[:SB]) if M > 1 else self.fill_tag.pos
        caches = []
        for k in range(self._copies):
            ports = []
            for bank in range(1 << bank_bits):
                # distributed RAM: a few words per slot, read and written every clock
                # (Yosys would otherwise take the registered read into a block RAM)
                mem = Memory(shape=unsigned(2 * STREAM_WIDTH), depth=self._depth >> bank_bits, init=[],
                             attrs={"ram_style": "distributed"})
                m.submodules[f"cache{k}_{bank}"] = mem
                wp = mem.write_port()
                m.d.comb += [wp.en.eq(self.fill_en & (fill_addr[in_bank:] == bank)),
                             wp.data.eq(self.fill_data), wp.addr.eq(fill_addr[:in_bank])]
                ports.append(mem.read_port(domain="comb"))
            caches.append(ports)
        for k, (name, copy, clocks) in enumerate(self._readers):
            self._read(m, platform, caches[copy], k, name, clocks)
        return m

    def _read(self, m, platform, ports, k, name, clocks):
        """The cache word at reader k's position of the visiting slot, the
        address registered in the visit, the word ``clocks`` clocks later in
        a register: with 2, each bank's word is registered first and the bank
        selected in the second clock (a selection among 16 LUT RAMs in one
        clock was n10_20_200's worst path, 7.2 ns); with 3, the banks are
        selected in two registered levels (``select_registered``)."""
        assert clocks in (1, 2, 3)
        M, SB, in_bank = self._slots, max(1, (self._slots - 1).bit_length()), self._in_bank
        pos = self.read_pos[k]
        # keep: else synthesis merges the register into the distributed
        # RAM's read port and moves it after the RAM, the address logic
        # and the RAM then in one clock (7.7 ns)
        full = Cat(pos[:POS_BITS], self.vslot[:SB]) if M > 1 else pos[:POS_BITS]
        addr = Signal(in_bank + self._bank_bits, name=f"{name}_addr", attrs={"keep": 1}, reset_less=True)
        m.d.sync += addr.eq(full)
        m.d.comb += self.read_addr[k].eq(addr)
        word = Signal(IQ(STREAM_WIDTH), name=name, reset_less=True)
        if len(ports) > 1:
            # each bank's LUT RAMs from a copy of their own (kept apart, as
            # the keep above does for one): one register reaching all four
            # banks' (128 at M = 10) was 6.2 ns in a two-pipeline build
            m.d.comb += [port.addr.eq(kept_register(m, platform, full[:in_bank], f"{name}_addr{b}"))
                         for b, port in enumerate(ports)]
        else:
            m.d.comb += ports[0].addr.eq(addr[:in_bank])
        words = [port.data for port in ports]
        bank = addr[in_bank:]
        if clocks >= 2:
            words = [delayed(m, w, 1, f"{name}_bank{b}", data=True) for b, w in enumerate(words)]
            if len(words) > 1:
                bank = delayed(m, bank, 1, f"{name}_bank", data=True)
        if clocks == 3:
            m.d.sync += word.eq(select_registered(m, words, bank, f"{name}_sel"))
        else:
            m.d.sync += word.eq(Array(words)[bank] if len(words) > 1 else words[0])
        m.d.comb += self.read_word[k].eq(word)
