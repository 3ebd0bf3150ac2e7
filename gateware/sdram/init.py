"""SDRAM initialisation without a CPU: LiteX BIOS's ``sdram_init`` as a ROM of
Wishbone writes to LiteDRAM's ``wb_ctrl`` bus."""

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from .generate import InitOp

__all__ = ["WishboneSignature", "SDRAMInit", "bios_sdram_init"]

#: LiteDRAM's DFII control register: bit 0 hands the DFI to the controller.
DFII_CONTROL_SEL = 0x01

#: LiteDRAM's ``wb_ctrl`` slave as seen by its master (classic Wishbone, 32-bit, word addresses).
WishboneSignature = wiring.Signature({
    "adr": Out(30), "dat_w": Out(32), "dat_r": In(32), "sel": Out(4),
    "cyc": Out(1), "stb": Out(1), "we": Out(1), "ack": In(1), "err": In(1),
    "cti": Out(3), "bte": Out(2),
})


def bios_sdram_init(core):
    """LiteX BIOS's ``sdram_init()`` for a generated core without leveling or
    memtest: the generator's ``init_sequence()`` (which starts by putting the
    DFII in software control with CKE high), then ``sdram_software_control_off``
    (DFII control = SEL: the controller drives the DFI, refresh starts) and
    ``init_done`` set (LiteDRAM then opens the user port)."""
    return (*core.init_ops,
            InitOp("write", core.csr["sdram_dfii_control"], DFII_CONTROL_SEL,
                   comment="hand over to the controller"),
            InitOp("write", core.csr["ddrctrl_init_done"], 1, comment="init done"))


class SDRAMInit(wiring.Component):
    """Runs ``ops`` (:class:`~rast.gateware.sdram.generate.InitOp`) once after
    reset as a Wishbone master, then raises ``init_done``.

    A write waits for ``ack`` (or ``err``, which sets ``init_error``); a wait of
    ``cdelay`` units lasts ``cdelay * cdelay_clocks`` clocks. LiteX's BIOS spins
    ``cdelay(n)`` for n loop iterations of its CPU, several clocks each, so one
    clock per unit is the shortest reading: ``cdelay(20000)`` is then 400 µs at
    50 MHz, more than the 100 µs the MT48LC16M16 asks for between a stable
    clock and the first command.

    Parameters
    ----------
    ops : sequence of InitOp
    cdelay_clocks : int
        Clocks per ``cdelay`` unit (positive).

    Members
    -------
    bus : Out(WishboneSignature)
    init_done : Out(1)
    init_error : Out(1)
    """

    def __init__(self, ops, *, cdelay_clocks=1):
        ops = tuple(ops)
        if not ops or not all(isinstance(o, InitOp) and o.kind in ("write", "wait") for o in ops):
            raise TypeError(f"Init operations must be a non-empty sequence of InitOp, not {ops!r}")
        if not (isinstance(cdelay_clocks, int) and not isinstance(cdelay_clocks, bool) and cdelay_clocks > 0):
            raise TypeError(f"Clocks per cdelay unit must be a positive integer, not {cdelay_clocks!r}")
        for o in ops:
            if o.kind == "write" and (o.addr & 3 or not 0 <= o.addr < 1 << 32 or not 0 <= o.data < 1 << 32):
                raise ValueError(f"Init write must have a word-aligned 32-bit address and 32-bit data, not {o!r}")
        self._ops, self._cdelay_clocks = ops, cdelay_clocks
        super().__init__({"bus": Out(WishboneSignature), "init_done": Out(1), "init_error": Out(1)})

    @property
    def ops(self):
        return self._ops

    @property
    def cycles(self):
        """Clocks the waits take (the writes add a few clocks each)."""
        return sum(o.cdelay for o in self._ops if o.kind == "wait") * self._cdelay_clocks

    def _rom(self):
        aw = max(1, max((o.addr >> 2).bit_length() for o in self._ops))
        words = []
        for o in self._ops:
            if o.kind == "write":
                words.append((o.data << (aw + 1)) | ((o.addr >> 2) << 1))
            else:
                words.append(((o.cdelay * self._cdelay_clocks) << (aw + 1)) | 1)
        return aw, words

    def elaborate(self, platform):
        m = Module()
        aw, words = self._rom()
        dw = max(32, max(w >> (aw + 1) for w in words).bit_length())
        m.submodules.rom = rom = Memory(shape=1 + aw + dw, depth=len(words), init=words)
        rd = rom.read_port(domain="comb")
        pc = Signal(range(len(words) + 1))
        count = Signal(dw)
        is_wait, addr, value = rd.data[0], rd.data[1:1 + aw], rd.data[1 + aw:]
        m.d.comb += [rd.addr.eq(pc), self.bus.sel.eq(0xF)]
        with m.FSM():
            with m.State("STEP"):
                with m.If(pc == len(words)):
                    m.next = "DONE"
                with m.Elif(is_wait):
                    m.d.sync += count.eq(value)
                    m.next = "WAIT"
                with m.Else():
                    m.d.comb += [self.bus.cyc.eq(1), self.bus.stb.eq(1), self.bus.we.eq(1),
                                 self.bus.adr.eq(addr), self.bus.dat_w.eq(value)]
                    with m.If(self.bus.ack | self.bus.err):
                        m.d.sync += pc.eq(pc + 1)
                        with m.If(self.bus.err):
                            m.d.sync += self.init_error.eq(1)
                        m.next = "GAP"
            with m.State("GAP"):
                # one idle clock between Wishbone cycles (classic Wishbone, no pipelining)
                m.next = "STEP"
            with m.State("WAIT"):
                with m.If(count <= 1):
                    m.d.sync += pc.eq(pc + 1)
                    m.next = "STEP"
                with m.Else():
                    m.d.sync += count.eq(count - 1)
            with m.State("DONE"):
                m.d.comb += self.init_done.eq(1)
        return m
