"""ECP5 primitives with their registers on, behind behavioural equivalents.

Each component elaborates to plain Amaranth (``lib.memory.Memory``, ``*``)
when ``platform`` is ``None`` or not an ECP5 (the Amaranth simulator, Verilog
for cocotb and Verilator) and to vendor primitives on an ECP5 platform:

* :class:`RegisteredRAM`: a simple dual-port RAM whose read data passes the
  block RAM's own output register (``DP16KD`` with ``REGMODE_B="OUTREG"``).
  Deep memories are *sliced by width*, never cascaded by depth: a 8192 x 32
  memory is sixteen ``DP16KD`` in 8192 x 2 mode, each holding two bits of
  every word, so there is no read multiplexer at all and every block RAM's
  output is registered inside the block RAM.
* :class:`RegisteredMultiplier`: a signed product registered in the
  ``MULT18X18D`` output register (``REG_OUTPUT_CLK="CLK0"``).
* :func:`kept_register`: a register that synthesis keeps as a copy of its
  own (``TRELLIS_FF`` instances), for fan-out trees.
* :func:`kept_lut`: a function of up to four bits in a LUT of its own
  (a ``LUT4`` instance), where logic synthesis would otherwise share a
  term with other logic and put a LUT level more on a path.
* :func:`local_constant`: a constant in a flip-flop of its own, for the
  distributed RAMs' pins nextpnr would otherwise route from one die-wide
  constant net; :func:`lut_ram_depth`, the depth that leaves a distributed
  RAM no constant address bit.

Why (measured, ``docs/bitstream.md``, "Why the block RAMs and multipliers are
instantiated"): Yosys did not place a following fabric register into these
primitives' registers, and the unregistered paths (block RAM clock-to-out
5.6 ns, multiplier 3.9 ns) limited a datapath of the replay block's shape to
80 MHz; with the primitives' registers on and the RAM addresses registered it
reached 202 MHz.
"""

from amaranth.hdl import Module, Signal, Value, Const, Cat, ClockSignal, ResetSignal, Instance, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

__all__ = ["RegisteredRAM", "RegisteredMultiplier", "kept_register", "kept_lut", "lut4_init", "is_ecp5",
           "local_constant", "lut_ram_depth", "LUT_RAM_WORDS",
           "dp16kd_mode", "DP16KD_MODES", "BLOCK_RAM_SITES", "block_ram_rows",
           "delay_line_floorplan"]

#: DP16KD data widths and depths (single port of the pair), widest last.
DP16KD_MODES = ((1, 16384), (2, 8192), (4, 4096), (9, 2048), (18, 1024))
#: Address bits below the word address in each mode (ADx[13:shift] is the address).
_ADDR_SHIFT = {1: 0, 2: 1, 4: 2, 9: 3, 18: 4}


#: The block-RAM sites of the devices whose floorplan is known, as nextpnr names
#: them (``X<x>/Y<y>/EBR<k>``): per device the rows' y and the x of each
#: column of four sites (EBR k at x + 2k). Read from nextpnr's placement of
#: a design that fills every DP16KD (nextpnr-ecp5 0.11, LFE5U-85F: four rows
#: of 52 sites, 208 in all); docs/bitstream.md, "The pool's block RAMs placed".
BLOCK_RAM_SITES = {
    "LFE5U-85F": ((22, 46, 70, 82), (4, 13, 22, 31, 40, 49, 58, 69, 78, 87, 96, 105, 114)),
}


def block_ram_rows(platform):
    """The block-RAM sites of ``platform``'s device as rows (each left to right,
    a list of nextpnr bel names), or ``None`` when the platform is not an ECP5
    device of :data:`BLOCK_RAM_SITES` (the placer then chooses freely)."""
    if not is_ecp5(platform) or getattr(platform, "device", None) not in BLOCK_RAM_SITES:
        return None
    ys, xs = BLOCK_RAM_SITES[platform.device]
    return [[f"X{x + 2 * k}/Y{y}/EBR{k}" for x in xs for k in range(4)] for y in ys]


def delay_line_floorplan(rows, reserve, block, count):
    """Sites for the delay lines where no pool's banks are placed (an SDRAM
    build): ``(reserved[row], blocks)``, ``reserve`` neighbouring sites in the
    middle of each row (the common line's share of it) and ``count`` blocks
    of ``block`` neighbouring sites (one per pipeline's window), taken from
    the rows in turn, in a checkerboard of the rows' left and right halves
    (row by row the first half alternates), spread evenly along the half.
    Without them the placer packed an SDRAM build's logic into one corner of
    the device, between the few RAMs and the SDRAM pins (docs/bitstream.md,
    "The SDRAM build's delay lines placed"); the pool's banks spread a
    block-RAM build the same way. ``None`` where ``rows`` is ``None`` or the
    blocks do not fit."""
    if rows is None:
        return None
    reserved, halves = [], []
    for row in rows:
        at = (len(row) - reserve) // 2
        reserved.append(row[at:at + reserve])
        halves.append((row[:at], row[at + reserve:]))
    where = [(i % len(rows), (i % len(rows) + i // len(rows)) % 2) for i in range(count)]
    per_half = {key: [i for i, w in enumerate(where) if w == key] for key in set(where)}
    blocks = [None] * count
    for (r, h), users in per_half.items():
        half, k = halves[r][h], len(users)
        if k * block > len(half):
            return None
        for j, i in enumerate(users):
            start = min(max(0, int((j + 0.5) * len(half) / k - block / 2)), len(half) - block)
            blocks[i] = half[start:start + block]
    return reserved, blocks


def is_ecp5(platform) -> bool:
    """Whether ``platform`` is an ECP5 (Amaranth's ``LatticeECP5Platform``, or
    anything with ``family == "ecp5"``, e.g. a stand-in in tests)."""
    return platform is not None and getattr(platform, "family", None) == "ecp5"


def kept_register(m, platform, value, name, *, reset=False, init=0, domain="sync"):
    """``value`` one clock of ``domain`` later, in a register of its own, its
    value at power-up ``init`` (with ``reset``, also after the domain's
    synchronous reset; else not reset).

    Copies of one register that differ in nothing are one register to Yosys
    (its ``opt_merge`` merges flip-flops with the same inputs; a ``keep``
    attribute on the signal does not stop it, only one on the cell, which
    Amaranth cannot set on a ``$dff``). A fan-out tree of such copies, each
    placed beside the block RAMs it feeds, needs them kept apart, so on ECP5
    each bit is a ``TRELLIS_FF`` instance, which Yosys does not merge; on
    other platforms a plain register.
    """
    value = Value.cast(value)
    q = Signal(len(value), name=name, reset_less=not reset, init=init)
    if not is_ecp5(platform):
        m.d[domain] += q.eq(value)
        return q
    for k in range(len(value)):
        # REGSET: the bit's value at power-up and after LSR (the synchronous reset)
        m.submodules[f"{name}_ff{k}"] = Instance(
            "TRELLIS_FF", p_GSR="DISABLED", p_CEMUX="1", p_CLKMUX="CLK", p_LSRMUX="LSR",
            p_REGSET="SET" if (init >> k) & 1 else "RESET", p_SRMODE="LSR_OVER_CE",
            i_CLK=ClockSignal(domain), i_LSR=ResetSignal(domain) if reset else Const(0),
            i_DI=value[k], o_Q=q[k])
    return q


#: Words of one distributed RAM primitive (``TRELLIS_DPR16X4``).
LUT_RAM_WORDS = 16


def lut_ram_depth(words: int) -> int:
    """The depth to give a distributed RAM of at least ``words`` words: a
    power of two and no less than LUT_RAM_WORDS, so that every address pin
    of its primitives is driven by an address bit (a RAM of 8 words ties
    its primitives' fourth address pin to the constant net, see
    :func:`local_constant`); the primitives are as many either way."""
    return max(LUT_RAM_WORDS, 1 << max(0, words - 1).bit_length())


def local_constant(m, platform, value, width, name):
    """``value`` (``width`` bits) for a group of distributed RAMs' input pins,
    on ECP5 held by flip-flops of their own (set at power-up, never loaded
    with anything else); elsewhere the constant itself.

    nextpnr's ECP5 packer folds a constant into a LUT's function or a block
    RAM's tie-offs, but routes the constant inputs of distributed RAMs (an
    always-on write enable, an address bit above the RAM's depth) from one
    die-wide net of its constant driver: 10,248 of the 11,894 pins on those
    nets in the 64-channel build, the nets router1 re-routed most in the
    end-games of its slow seeds (docs/bitstream.md, "The constant nets"). A
    flip-flop per RAM group makes each a net beside its RAMs, like their
    address counters'."""
    if not is_ecp5(platform):
        return Const(value, width)
    return kept_register(m, platform, Const(value, width), name, init=value)


def lut4_init(fn, inputs=4):
    """The ``INIT`` of an ECP5 ``LUT4`` computing ``fn`` of its first
    ``inputs`` pins (A the first argument, then B, C, D; the LUT's output
    for pins DCBA = k is INIT bit k). ``fn`` is written with ``&``, ``|``,
    ``^`` and ``~`` only, so that it means the same on bits as on Amaranth
    values; unused pins do not matter."""
    init = 0
    for k in range(16):
        init |= (fn(*((k >> j) & 1 for j in range(inputs))) & 1) << k
    return init


def kept_lut(m, platform, inputs, fn, name):
    """``fn(*inputs)`` of up to four one-bit ``inputs``, combinational, in a
    LUT of its own: on ECP5 a ``LUT4`` instance, which synthesis neither
    merges into other logic nor builds from terms it shares with other
    logic; elsewhere the plain expression. Where a function of eight bits
    needs two LUT levels, ABC sometimes shares a two-input term with
    another signal and makes it three (the switch of the channel pipeline,
    docs/bitstream.md); a kept LUT for four of the bits leaves the rest one
    LUT."""
    inputs = [Value.cast(v) for v in inputs]
    if not 1 <= len(inputs) <= 4 or any(len(v) != 1 for v in inputs):
        raise ValueError(f"Inputs must be one to four one-bit values, not {inputs!r}")
    z = Signal(name=name)
    if not is_ecp5(platform):
        m.d.comb += z.eq(fn(*inputs))
        return z
    pins = inputs + [Const(0, 1)] * (4 - len(inputs))
    m.submodules[f"{name}_lut"] = Instance(
        "LUT4", p_INIT=Const(lut4_init(fn, len(inputs)), 16),
        i_A=pins[0], i_B=pins[1], i_C=pins[2], i_D=pins[3], o_Z=z)
    return z


def dp16kd_mode(width: int, depth: int):
    """``(mode_width, slices)`` of the widest DP16KD mode holding ``depth`` words
    (the fewest block RAMs), or ``None`` when ``depth`` exceeds 16384 (no width
    slicing possible)."""
    for w, d in reversed(DP16KD_MODES):
        if d >= depth:
            return w, -(-width // w)
    return None


class RegisteredRAM(wiring.Component):
    """Simple dual-port RAM, read latency 2 (3 with ``addr_reg``), every read
    stage enabled by ``r_en``.

    In a cycle with ``r_en``, the word at ``r_addr`` is read into the read
    stage and the previous read stage moves to ``r_data`` (so ``r_data`` shows
    the word addressed two enabled cycles before). With ``addr_reg``,
    ``r_addr`` first goes through a fabric register of its own (one more
    enabled cycle): a register next to the block RAMs, so the logic making
    the address is not pulled towards the RAMs it fans out to. The read stage
    has no defined power-up value, so until it has been loaded (the first
    enabled cycle, the first two with ``addr_reg``) ``r_data`` stays 0. ``r_data`` is reset
    with the domain. Writes (``w_en``) take effect at the clock edge. A read
    of the address being written in the same cycle returns the old word in
    the behavioural path only: a DP16KD does not promise it (no
    read-before-write across ports), so a design must not rely on it
    (docs/netlist_sim.md).

    With ``continuous`` there is no ``r_en``: every clock reads, and the
    block RAMs' clock enables are tied high. ``r_data`` is then not held at
    0 until the read stage is loaded (0 in reset, then what the read stage
    holds), so there is no "primed" flip-flop, which Yosys merges across
    RAMs into one driving every block RAM's output enable (the pool's worst
    path, 8.5 ns, in a 10-channel build).

    With ``output_reset`` False (continuous RAMs only) ``r_data`` is not
    reset either: a RAM whose words are data, read only under strobes that
    are reset (the engine's pool and delay lines), then has no reset net
    reaching its block RAMs. (The reset reached a window's block RAM in
    fabric from the register before its global buffer: 9.1 ns, the latest
    path of a four-pipeline build.)

    Parameters
    ----------
    width, depth : int
    init : sequence of int
        Power-up contents. On ECP5 a memory with initial contents is left to
        Yosys's inference (the primitive path has no INITVAL packing).
    addr_reg : bool
        Register the read address first (latency 3).
    block_ram : bool
        On ECP5, DP16KD primitives (default); ``False`` leaves a small memory
        to Yosys (distributed RAM for a few dozen words).
    continuous : bool
        Read every clock (no ``r_en``).
    output_reset : bool
        Clear ``r_data`` with the domain's reset (default); ``False`` only
        with ``continuous``.
    sites : sequence of str, optional
        On ECP5, the bel of each DP16KD slice (lowest bits first), as nextpnr
        names them (:func:`block_ram_rows`): the slices are placed there
        (nextpnr's ``BEL`` attribute) instead of where the placer puts them.
        Not used where the RAM is left to Yosys (``init``, ``block_ram=False``).

    Members
    -------
    w_en : In(1), w_addr : In(range(depth)), w_data : In(width)
    r_en : In(1) (not with ``continuous``), r_addr : In(range(depth)), r_data : Out(width)
    """

    def __init__(self, width, depth, init=(), *, addr_reg=False, block_ram=True, continuous=False,
                 sites=None, output_reset=True):
        if not isinstance(width, int) or isinstance(width, bool) or width <= 0:
            raise TypeError(f"RAM width must be a positive integer, not {width!r}")
        if not isinstance(depth, int) or isinstance(depth, bool) or depth < 2:
            raise TypeError(f"RAM depth must be an integer of at least 2, not {depth!r}")
        if not isinstance(addr_reg, bool):
            raise TypeError(f"Address register must be a bool, not {addr_reg!r}")
        self._width, self._depth, self._init = width, depth, list(init)
        if not isinstance(block_ram, bool):
            raise TypeError(f"Block RAM must be a bool, not {block_ram!r}")
        if not isinstance(continuous, bool):
            raise TypeError(f"Continuous must be a bool, not {continuous!r}")
        if sites is not None:
            mode = dp16kd_mode(width, depth)
            sites = tuple(sites)
            if mode is None or not all(isinstance(x, str) for x in sites) or len(sites) != mode[1]:
                raise ValueError(f"RAM sites must be {mode[1] if mode else 'no'} bel names (one per "
                                 f"block RAM of a {depth} x {width} RAM), not {sites!r}")
        if not isinstance(output_reset, bool):
            raise TypeError(f"Output reset must be a bool, not {output_reset!r}")
        if not output_reset and not continuous:
            raise ValueError("Output reset may be left out only with continuous reads (a RAM with "
                             "r_en holds r_data at 0 until primed, through its reset)")
        self._output_reset = output_reset
        self._addr_reg = addr_reg
        self._block_ram = block_ram
        self._continuous = continuous
        self._sites = sites
        super().__init__({
            "w_en": In(1), "w_addr": In(range(depth)), "w_data": In(width),
            **({} if continuous else {"r_en": In(1)}),
            "r_addr": In(range(depth)), "r_data": Out(width),
        })

    @property
    def width(self):
        return self._width

    @property
    def latency(self):
        return 3 if self._addr_reg else 2

    def _read_enable(self):
        return Const(1) if self._continuous else self.r_en

    def _read_front(self, m):
        """The read address as the RAM sees it, and ``primed``: the read stage holds
        a word read from memory (so ``r_data`` may load)."""
        ra = self.r_addr
        r_en = self._read_enable()
        if self._addr_reg:
            ra = Signal.like(self.r_addr, name="r_addr_q")
            with m.If(r_en):
                m.d.sync += ra.eq(self.r_addr)
        if self._continuous:
            return ra, Const(1)
        fill = Signal(range(self.latency))           # enabled cycles seen, saturating
        primed = Signal()                            # == (fill == latency - 1), as a flip-flop:
        with m.If(self.r_en & ~primed):              # it fans out to every slice's OCE
            m.d.sync += fill.eq(fill + 1)
            with m.If(fill == self.latency - 2):
                m.d.sync += primed.eq(1)
        return ra, primed

    @property
    def depth(self):
        return self._depth

    def block_rams(self, platform=None):
        """DP16KD used on ECP5 (0 when the behavioural path is taken)."""
        mode = dp16kd_mode(self._width, self._depth)
        return mode[1] if mode and not self._init and self._block_ram else 0

    def elaborate(self, platform):
        mode = dp16kd_mode(self._width, self._depth)
        if is_ecp5(platform) and mode is not None and not self._init and self._block_ram:
            return self._elaborate_ecp5(*mode)
        m = Module()
        m.submodules.storage = mem = Memory(shape=unsigned(self._width), depth=self._depth,
                                        init=self._init)
        wr = mem.write_port()
        rd = mem.read_port(domain="sync")
        r_addr, primed = self._read_front(m)
        r_en = self._read_enable()
        m.d.comb += [wr.en.eq(self.w_en), wr.addr.eq(self.w_addr), wr.data.eq(self.w_data),
                     rd.en.eq(r_en), rd.addr.eq(r_addr)]
        r_data = self.r_data
        if not self._output_reset:
            r_data = Signal.like(self.r_data, name="r_data_q", reset_less=True)
            m.d.comb += self.r_data.eq(r_data)
        with m.If(r_en & primed):
            m.d.sync += r_data.eq(rd.data)
        return m

    def _elaborate_ecp5(self, w, slices):
        m = Module()
        r_addr, primed = self._read_front(m)
        s = _ADDR_SHIFT[w]
        aw = 14 - s
        wa = Signal(14)
        ra = Signal(14)
        m.d.comb += [wa.eq(self.w_addr << s), ra.eq(r_addr << s)]
        if w == 18:                              # ADA[1:0] are the byte write enables
            m.d.comb += wa[:2].eq(0b11)
        # OCEB is high in reset too: the block RAM's synchronous reset of its output
        # register only acts at a clock edge with OCE high (the reading of TN1264
        # taken in docs/netlist_sim.md); without it a reset while the read stage
        # is not primed left the old word on r_data (the netlist cosimulation,
        # tests/test_netlist_ram.py, showed it).
        r_en = self._read_enable()
        oce = Signal()
        m.d.comb += oce.eq(1 if self._continuous else (r_en & primed) | ResetSignal("sync"))
        padded_w = Signal(slices * w)
        padded_r = Signal(slices * w)
        m.d.comb += [padded_w.eq(self.w_data), self.r_data.eq(padded_r)]
        for k in range(slices):
            di = Signal(18, name=f"di{k}")
            do = Signal(18, name=f"do{k}")
            m.d.comb += [di.eq(padded_w[k * w:(k + 1) * w]), padded_r[k * w:(k + 1) * w].eq(do[:w])]
            ports = {}
            for b in range(18):
                ports[f"i_DIA{b}"] = di[b]
                ports[f"i_DIB{b}"] = Const(0)
                ports[f"o_DOB{b}"] = do[b]
            for b in range(14):
                ports[f"i_ADA{b}"] = wa[b]
                ports[f"i_ADB{b}"] = ra[b]
            for b in range(3):
                ports[f"i_CSA{b}"] = Const(0)
                ports[f"i_CSB{b}"] = Const(0)
            if self._sites is not None:
                ports["a_BEL"] = self._sites[k]
            m.submodules[f"bram{k}"] = Instance(
                "DP16KD",
                p_DATA_WIDTH_A=w, p_DATA_WIDTH_B=w,
                p_REGMODE_A="NOREG", p_REGMODE_B="OUTREG",
                p_RESETMODE="SYNC", p_ASYNC_RESET_RELEASE="SYNC",
                p_CSDECODE_A="0b000", p_CSDECODE_B="0b000",
                p_WRITEMODE_A="NORMAL", p_WRITEMODE_B="NORMAL",
                p_GSR="DISABLED",
                i_CLKA=ClockSignal("sync"), i_CEA=Const(1), i_OCEA=Const(1), i_WEA=self.w_en,
                i_RSTA=Const(0),
                i_CLKB=ClockSignal("sync"), i_CEB=r_en, i_OCEB=oce, i_WEB=Const(0),
                i_RSTB=ResetSignal("sync") if self._output_reset else Const(0),
                **ports)
        return m


class RegisteredMultiplier(wiring.Component):
    """``o = a * b`` (signed), registered, advancing when ``en``.

    On ECP5 one ``MULT18X18D`` with its output register, and with
    ``input_reg`` its input registers too; operands up to 18 bits each. The
    registers are reset with the domain.

    Parameters
    ----------
    a_width, b_width : int
    input_reg : bool
        Register the operands inside the multiplier (latency 2, else 1).

    Members
    -------
    en : In(1)
    a : In(signed(a_width)), b : In(signed(b_width))
    o : Out(signed(a_width + b_width))
    """

    def __init__(self, a_width, b_width, *, input_reg=False):
        for name, v in (("Operand A width", a_width), ("Operand B width", b_width)):
            if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= 18:
                raise ValueError(f"{name} must be an integer in [1, 18], not {v!r}")
        if not isinstance(input_reg, bool):
            raise TypeError(f"Input register must be a bool, not {input_reg!r}")
        self._aw, self._bw, self._input_reg = a_width, b_width, input_reg
        super().__init__({
            "en": In(1),
            "a": In(signed(a_width)),
            "b": In(signed(b_width)),
            "o": Out(signed(a_width + b_width)),
        })

    @property
    def latency(self):
        return 2 if self._input_reg else 1

    def elaborate(self, platform):
        m = Module()
        if not is_ecp5(platform):
            a, b = self.a, self.b
            if self._input_reg:
                a, b = Signal.like(self.a), Signal.like(self.b)
                with m.If(self.en):
                    m.d.sync += [a.eq(self.a), b.eq(self.b)]
            with m.If(self.en):
                m.d.sync += self.o.eq(a * b)
            return m
        inreg = "CLK0" if self._input_reg else "NONE"
        a18 = Signal(signed(18))
        b18 = Signal(signed(18))
        p = Signal(36)
        m.d.comb += [a18.eq(self.a), b18.eq(self.b), self.o.eq(p[:self._aw + self._bw])]
        ports = {}
        for k in range(18):
            ports[f"i_A{k}"] = a18[k]
            ports[f"i_B{k}"] = b18[k]
            ports[f"i_C{k}"] = Const(0)
        for k in range(36):
            ports[f"o_P{k}"] = p[k]
        m.submodules.mult = Instance(
            "MULT18X18D",
            p_REG_INPUTA_CLK=inreg, p_REG_INPUTB_CLK=inreg, p_REG_INPUTC_CLK="NONE",
            p_REG_INPUTA_CE="CE0", p_REG_INPUTB_CE="CE0",
            p_REG_INPUTA_RST="RST0", p_REG_INPUTB_RST="RST0",
            p_REG_PIPELINE_CLK="NONE", p_REG_OUTPUT_CLK="CLK0",
            p_REG_OUTPUT_CE="CE0", p_REG_OUTPUT_RST="RST0",
            p_CLK0_DIV="ENABLED", p_CLK1_DIV="ENABLED", p_CLK2_DIV="ENABLED", p_CLK3_DIV="ENABLED",
            p_HIGHSPEED_CLK="NONE", p_GSR="DISABLED", p_CAS_MATCH_REG="FALSE",
            p_SOURCEB_MODE="B_SHIFT", p_MULT_BYPASS="DISABLED", p_RESETMODE="SYNC",
            i_SIGNEDA=Const(1), i_SIGNEDB=Const(1), i_SOURCEA=Const(0), i_SOURCEB=Const(0),
            i_CLK0=ClockSignal("sync"), i_CE0=self.en, i_RST0=ResetSignal("sync"),
            i_CLK1=Const(0), i_CLK2=Const(0), i_CLK3=Const(0),
            i_CE1=Const(0), i_CE2=Const(0), i_CE3=Const(0),
            i_RST1=Const(0), i_RST2=Const(0), i_RST3=Const(0),
            **ports)
        return m
