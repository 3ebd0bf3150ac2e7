"""Memory-mapped register file, generated from ``rast.model.contract.regmap``."""

from types import SimpleNamespace

from amaranth.hdl import Module, Signal, Const, Mux, Cat, Array, Value
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from rast.model.contract.regmap import RegisterMap, CRC32_POLY, STORED, SCAN_RESTART, FOLLOW_SWITCH_STEP_BITS
from rast.model.contract.fixedpoint import STREAM_WIDTH, REGISTER_STAGING
from rast.model.contract.scan import AZIMUTH_BITS, PATTERN_INDEX_BITS, PATTERN_WIDTH
from .ecp5_primitives import kept_register, local_constant, lut_ram_depth
from .scan_generator import SCAN_SETTINGS
from .follow.assigner import follow_settings_layout
from rast.model.contract.follow import FOLLOW_ROW_WORDS

#: Low address bits decoded apart from the rest for the write strobes (RegisterFile).
PREDECODE_BITS = 4

__all__ = ["BusSignature", "RegisterFile", "channel_regs_layout", "slot_values_layout", "SLOT_RAM_FIELDS",
           "slot_ram_fields", "crc32_step", "CRC_CLOCKS", "MATCH_STAGES"]

#: The per-channel values the engine reads by slot from a distributed RAM per
#: group of channels (a pipeline's): name in ``slot_values_layout`` ->
#: (register, field).
SLOT_RAM_FIELDS = {"gain": ("GAIN", "gain"), "length": ("LENGTH", "length"),
                   "increment": ("PHASE_INC", "inc"), "base": ("BASE", "base")}



def slot_ram_fields(rmap: RegisterMap) -> dict:
    """SLOT_RAM_FIELDS, AZIMUTH's where the block has the antenna scan and
    START's where its streams start at a fraction of a word."""
    c = rmap.contract
    return {**SLOT_RAM_FIELDS, **({"azimuth": ("AZIMUTH", "azimuth")} if c.scan else {}),
            **({"start": ("START", "frac")} if c.start_frac else {})}


def ram_fields(rmap: RegisterMap) -> dict:
    """Every per-channel field the host writes that is kept in its group's
    distributed RAMs (and in no flip-flop): the engine's, and the CRC the SWAP
    check compares."""
    return {**slot_ram_fields(rmap), "crc": ("CRC", "crc")}


def read_back_ram(rmap: RegisterMap) -> dict:
    """The per-channel fields read back from those RAMs: the readable ones, and
    PLAYED (a RAM of the group's too, written by a SWAP taken)."""
    return {**{name: rf for name, rf in ram_fields(rmap).items() if rf != ("CRC", "crc")},
            "played": ("PLAYED", "crc")}


def crc32_step(crc, bits):
    """The CRC-32 register (reflected, ``CRC32_POLY``, not inverted) after the
    value ``bits`` (b of them) shifted in, least significant first:
    ``(crc >> b) ^ T_b(crc[:b] ^ bits)``, T_b linear over GF(2), so every bit is
    one bit of ``crc`` XOR a few of the b bits. A word is its four bytes in
    little-endian order, as ``zlib.crc32`` reads them; from ``0xFFFFFFFF``, the
    register XOR ``0xFFFFFFFF`` is zlib's CRC-32."""
    b = len(bits)

    def steps(x):
        for _ in range(b):
            x = (x >> 1) ^ (CRC32_POLY if x & 1 else 0)
        return x
    columns = [steps(1 << j) for j in range(b)]
    v = crc[:b] ^ bits
    out = []
    for i in range(32):
        acc = crc[i + b] if i + b < 32 else Const(0, 1)
        for j in range(b):
            if columns[j] >> i & 1:
                acc = acc ^ v[j]
        out.append(acc)
    return Cat(*out)


#: Registered levels of the SWAP check (the run's start, words and CRC
#: against a channel's BASE, LENGTH and CRC): the RAMs' words registered,
#: the comparisons in parts of 8 bits, their AND (about 60 bits compared in
#: one clock was a 200 MHz build's worst path, 7.2 ns; the RAMs' read and
#: the comparison in one clock 9.8 ns at 64 channels, docs/bitstream.md).
#: Each level is a clock of the write's staging (REGISTER_STAGING), from the
#: bus's register on; the first reads the check's RAMs.
MATCH_STAGES = 3
#: Clocks the stream CRC takes per word after the clock that loads it into
#: a shift register: a byte a clock keeps each step's XORs sparse (one
#: register bit and a few of the byte's), where a word a clock is a dense
#: network of the register in its own loop, and the landing word straight
#: into the XORs was a 200 MHz build's worst path (6.8 ns). The CRC and the
#: SWAP check are complete before the next write lands (TAKE_SPACING).
CRC_CLOCKS = 4


class BusSignature(wiring.Signature):
    """A minimal register bus, seen from the host (initiator).

    One access at a time: the initiator holds ``addr`` with ``w_stb`` and
    ``w_data`` (a write) or with ``r_stb`` (a read) until a cycle in which
    ``ready`` is high; the access is taken in that cycle. A read's data is on
    ``r_data`` in the cycle ``r_valid`` is high, a fixed number of cycles later
    (reads are taken in order and may overlap).
    """

    def __init__(self, addr_width, data_width=32):
        super().__init__({
            "addr": Out(addr_width),
            "w_stb": Out(1),
            "w_data": Out(data_width),
            "r_stb": Out(1),
            "ready": In(1),
            "r_data": In(data_width),
            "r_valid": In(1),
        })


def channel_regs_layout(rmap: RegisterMap) -> data.StructLayout:
    """What the engine reads of one channel's registers from flip-flops in
    its slot: CTRL.enable, the applied tap (APPLY sets every channel's at
    once) and the pending CTRL command (a CTRL write not yet seen by the
    channel) as the three decisions it stands for: ``force_swap`` (a
    disabling write with an accepted swap: switch whatever the state),
    ``force_pending`` (a disabling write: switch if a swap is pending) and
    ``swap_req`` (an accepted swap). Each is set by the CTRL write and
    cleared when the engine reads the channel. (Formed by the engine from
    the command's valid, enable and swap bits after its slot selection,
    they were a LUT level more on the selection's path, the latest path of
    the 48-channel SDRAM build at 160 MHz, 6.34 ns.)"""
    return data.StructLayout({
        "enable": 1,
        "tap": rmap.reg("DELAY", 0).field("delay").width,
        "force_swap": 1,
        "force_pending": 1,
        "swap_req": 1,
    })


def slot_values_layout(rmap: RegisterMap) -> data.StructLayout:
    """What the engine reads of one channel's registers from its group's
    distributed RAM, by slot (``slot_ram_fields``)."""
    return data.StructLayout({name: rmap.reg(reg, 0).field(field).width
                              for name, (reg, field) in slot_ram_fields(rmap).items()})


class RegisterFile(wiring.Component):
    """Storage, commands and read-back for every register of ``rmap``.

    The engine's timing decides when the bus may be taken and when what is
    taken lands: ``take`` (from the engine) is the bus's ``ready``; a write
    taken in cycle t lands (storage, commands, APPLY, the pool write) in cycle
    ``t + REGISTER_STAGING``. A read taken in cycle t samples the stored values in
    cycle ``t + REGISTER_STAGING``, the engine's per-channel state mirrors
    (CTRL.swap, CTRL.bank) in cycle ``t + mirror_delay`` and the sticky
    overflow flag in cycle ``t + status_delay`` (clearing it there), so that
    every part of the answer is the state between the same two steps; the
    answer is on ``r_data`` with ``r_valid`` ``read_latency`` cycles after t.
    ``take`` must be high at most once in TAKE_SPACING clocks, as the
    engine's is (``take_interval``): a stream word's CRC and the SWAP check
    are complete before the next access lands, and the read-back reads its
    RAMs two clocks before it samples the other registers.

    The stream check: the start address, count and CRC-32 of the STREAM_DATA
    words landed since the last STREAM_ADDR write are kept; a CTRL write's
    swap reaches the engine only if they equal the channel's BASE, LENGTH and
    CRC as stored before it landed, each written since reset, and sets the
    channel's CTRL.rejected otherwise (``docs/registers.md``; the model: ``ReplayModel.write``).

    Parameters
    ----------
    rmap : RegisterMap
    mirror_delay, status_delay : int
        Cycles from a taken access to its sampling points (see above).
    scan_delay : int
        With the antenna scan: cycles from a taken read to the sampling of
        the beam's generator (SCAN_STATUS, ACP_PER_REV, STATUS.arp_lost).
    groups : list of lists of channels, optional
        Channels whose registers sit together (a pipeline's; all channels if
        not given): each group takes a registered copy of a write's data of
        its own, so the data does not fan out to every channel, and keeps
        its channels' ``SLOT_RAM_FIELDS`` in distributed RAMs, channel
        ``groups[g][s]`` at slot s.
    slots : int, optional
        Slots per group (its RAMs' depth; the longest group if not given):
        a slot without a channel reads 0.

    Members
    -------
    bus : In(BusSignature)
    take : In(1)
        The bus may be taken in this cycle.
    regs : Out(channel_regs_layout).array(N)
        Per channel: CTRL.enable, the applied tap, the pending command.
    values : Out(slot_values_layout).array(G)
        Per group, registered: the stored ``SLOT_RAM_FIELDS`` of one slot as
        they were in the clock before, the slots taken in turn from
        ``slots - 1`` at reset, one a clock (as a pipeline's slot counter
        reads its registers).
    cmd_ack : In(1).array(N)
        The engine read channel l's registers: its command is consumed.
    common_delay_next : Out
        The common delay applied from the next clock on (COMMON_DELAY as
        APPLY copies it): the common line's read is asked a clock ahead.
    pending, bank : In(1).array(N)
        The channels' state, from the engine.
    wr_en : Out(1), wr_addr : Out(pool address), wr_data : Out(32)
        Pool write, registered (the cycle after a STREAM_DATA write lands).
    overflow_set : In(1)
        An output sample saturated (its saturation register is loaded) in this cycle.
    overflow : Out(1)
        The sticky overflow flag.
    underflow_set : In(1), underflow : Out(1)
        The same for STATUS.underflow (a stream word read before it arrived).
    scan : Out(SCAN_SETTINGS), scan_restart : Out(1), with the antenna scan
        The beam's settings (stored) and SCAN_CTRL.restart in the clock its
        write lands.
    pattern_shift, pattern_floor : Out, pattern_w_en, pattern_w_addr, pattern_w_data : Out
        PATTERN's fields; the table's write, registered (the clock after a
        PATTERN_DATA write lands).
    scan_beam, scan_lost, scan_learned, scan_per_rev : In
        The generator's state, read back in SCAN_STATUS, STATUS and ACP_PER_REV.
    """

    def __init__(self, rmap: RegisterMap, *, mirror_delay=1, status_delay=1, groups=None,
                 slots=None, scan_delay=REGISTER_STAGING):
        if not isinstance(rmap, RegisterMap):
            raise TypeError(f"Register map must be a RegisterMap, not {rmap!r}")
        N = rmap.contract.channels
        groups = [list(range(N))] if groups is None else [list(g) for g in groups]
        if sorted(ch for g in groups for ch in g) != list(range(N)):
            raise ValueError(f"Groups must hold every channel 0..{N - 1} once, not {groups!r}")
        if any(g != list(range(g[0], g[0] + len(g))) for g in groups):
            # (a group's RAM range, ram_range below, is from its first channel to its last)
            raise ValueError(f"Groups must each be a run of consecutive channels in order, not {groups!r}")
        self._groups = groups
        longest = max(len(g) for g in groups)
        slots = longest if slots is None else slots
        if not isinstance(slots, int) or isinstance(slots, bool) or slots < longest:
            raise ValueError(f"Slots must be an integer of at least the longest group's {longest} "
                             f"channels, not {slots!r}")
        self._slots = slots
        for name, v in (("Mirror delay", mirror_delay), ("Status delay", status_delay), ("Scan delay", scan_delay)):
            if not isinstance(v, int) or isinstance(v, bool) or v < 0:
                raise ValueError(f"{name} must be an integer of at least 0, not {v!r}")
        self._rmap = rmap
        self._mirror_delay, self._status_delay, self._scan_delay = mirror_delay, status_delay, scan_delay
        c = rmap.contract
        N = c.channels
        self._cw = rmap.reg("COMMON_DELAY").field("delay").width
        super().__init__({
            "bus": In(BusSignature(rmap.addr_width)),
            "take": In(1),
            "regs": Out(channel_regs_layout(rmap)).array(N),
            "values": Out(slot_values_layout(rmap)).array(len(groups)),
            "cmd_ack": In(1).array(N),
            "common_delay_next": Out(self._cw),
            "pending": In(1).array(N),
            "bank": In(1).array(N),
            "wr_en": Out(1),
            "wr_addr": Out(c.pool_address_width),
            "wr_data": Out(2 * STREAM_WIDTH),
            "overflow_set": In(1),
            "overflow": Out(1),
            "underflow_set": In(1),
            "underflow": Out(1),
            **({"check_start": Out(1), "check_addr": Out(c.pool_address_width),
                "check_words": Out(c.length_width), "check_busy": In(1), "check_crc": In(32)}
               if rmap.has("POOL_CHECK") else {}),
            **({"scan": Out(SCAN_SETTINGS), "scan_restart": Out(1),
                "pattern_shift": Out(3), "pattern_floor": Out(PATTERN_WIDTH),
                "pattern_w_en": Out(1), "pattern_w_addr": Out(PATTERN_INDEX_BITS),
                "pattern_w_data": Out(PATTERN_WIDTH),
                "scan_beam": In(AZIMUTH_BITS), "scan_lost": In(1), "scan_learned": In(1),
                "scan_per_rev": In(17)} if c.scan else {}),
            **({"step_lo": In(FOLLOW_SWITCH_STEP_BITS), "land_tick": In(1), "land_step": In(1)}
               if c.start_frac else {}),
            **({"follow": Out(follow_settings_layout(c.follow_rows)), "follow_on": Out(1), "follow_start": Out(1),
                "table_w_en": Out(1), "table_w_addr": Out(range(FOLLOW_ROW_WORDS * c.follow_rows)),
                "table_w_data": Out(32), "follow_late_set": In(1), "follow_overrun_set": In(1)}
               if c.follow_rows else {}),
        })

    @property
    def rmap(self):
        return self._rmap

    #: Registered levels of the read-back multiplexer behind the sampling points.
    SELECT_LEVELS = 4

    @property
    def read_latency(self) -> int:
        """Cycles from a taken read to ``r_valid``."""
        return max(REGISTER_STAGING, self._mirror_delay, self._status_delay, self._scan_delay) + self.SELECT_LEVELS + 1

    def elaborate(self, platform):
        m = Module()
        m.d.comb += self.bus.ready.eq(self.take)
        # every stage reads the names the stages before it made (``env``)
        env = SimpleNamespace(m=m, platform=platform, rmap=self._rmap, bus=self.bus, c=self._rmap.contract,
                            N=self._rmap.contract.channels)
        for stage in (self._staging, self._landing, self._storage_writes, self._stream_run, self._slot_rams,
                      self._swap_check, self._follow_switch, self._commands, self._common_delay, self._pool_write,
                      self._status, self._scan, self._follow, self._read_back):
            stage(env)
        return m

    def _staging(self, env):
        """The access as it travels down its register pipeline, each group's copy
        of its stages, and the decodes from them a clock or more before the
        write lands (``at``, ``decoded``, ``landing``, ``writes``, ``clamped_value``)."""
        m, platform, rmap, bus, N = env.m, env.platform, env.rmap, env.bus, env.N
        # The access travels down a register pipeline, one stage per cycle.
        op = data.StructLayout({"valid": 1, "write": 1, "addr": len(bus.addr), "data": 32})
        depth = self.read_latency
        stage = [Signal(op, name="op0")] + [Signal(op, name=f"op{k}") for k in range(1, depth + 1)]
        taken = self.take & (bus.w_stb | bus.r_stb)
        m.d.comb += [stage[0].valid.eq(taken), stage[0].write.eq(bus.w_stb),
                     stage[0].addr.eq(bus.addr), stage[0].data.eq(bus.w_data)]
        m.d.sync += [stage[k].eq(stage[k - 1]) for k in range(1, depth + 1)]

        # Each group of channels (a pipeline's) decodes the access from a
        # copy of the stages of its own, from stage 1 on (kept apart from the
        # others, so that synthesis does not merge them back): one copy read
        # by every group's decoders fanned out to all of the engine's
        # register logic, and from it the read-back's hits, a RAM's write
        # enable, the SWAP check's hit flags and the landing data were the
        # latest paths of the 64-channel build (6.7-7.7 ns, most of it
        # routing). The global registers decode from ``stage``.
        unit_of = {ch: g for g, members in enumerate(self._groups) for ch in members}
        chains = {None: stage}
        for g in range(len(self._groups)):
            chains[g] = [stage[0], op(kept_register(m, platform, stage[0].as_value(), f"op1_g{g}", reset=True))]

        def at(unit, k):
            """Stage k of the access as group ``unit`` (None: the global
            registers) sees it; a group's stages are made as needed."""
            chain = chains[unit]
            while len(chain) <= k:
                nxt = Signal(op, name=f"op{len(chain)}_g{unit}")
                m.d.sync += nxt.eq(chain[-1])
                chain.append(nxt)
            return chain[k]

        in_ram = {(reg, field) for reg, field in ram_fields(rmap).values()}
        storage = {}          # (reg name, channel, field name) -> Signal; ram_fields are in RAMs
        for r in rmap.registers:
            for f in r.fields:
                if f.access in STORED and not (r.channel is not None and (r.name, f.name) in in_ram):
                    storage[(r.name, r.channel, f.name)] = Signal(
                        f.width, init=f.reset, name=f"{r.name.lower()}{'' if r.channel is None else r.channel}_{f.name}")

        # The write is decoded before it lands, into registers: per register
        # a write strobe, per group of channels (and one for the global
        # registers) a copy of the data and of the clamped field values,
        # zero unless the write addresses one of the group's registers or
        # APPLY (so the copies differ in logic and are not merged back into
        # one by synthesis). Landing is register to register; the address
        # compares and the clamps' comparators are a clock earlier still, in
        # ``decoded`` (the 10-channel build's critical path was op -> compare
        # -> clamp -> LENGTH). Each group decodes from its own stages
        # (``at``).
        wd = REGISTER_STAGING

        def decoded(fn, shape, name, unit):
            """fn(op) of the access in stage wd - 1, registered from stage wd - 2."""
            s = Signal(shape, name=f"{name}_{_unit_tag(unit)}")
            m.d.sync += s.eq(fn(at(unit, wd - 2)))
            return s

        def landing(value, shape, name, *, data=False):
            """``value`` registered; ``data``: not reset (read only under a
            strobe that is; the reset, merged into the data's logic by
            synthesis, was a 200 MHz build's worst path, 6.9 ns)"""
            s = Signal(shape, name=name, reset_less=data)
            m.d.sync += s.eq(value)
            return s

        # A register's write strobe, "the access in stage wd - 1 writes address
        # a", is the AND of three ``decoded`` bits: valid & write, and one-hot
        # bits of the address's low PREDECODE_BITS and of the rest. Each of
        # those is one LUT from its stage, and the strobe one LUT into its
        # landing register. Decoding the whole address into every strobe in
        # one clock was three LUT levels behind a long route from the stage
        # register (n10_20_200's worst path, op1 -> hit_phase_inc7, 7.0 ns).
        decoded_bits = {}

        def decoded_bit(key, fn, unit):
            if (unit, key) not in decoded_bits:
                decoded_bits[(unit, key)] = decoded(fn, 1, f"pre_{key}", unit)
            return decoded_bits[(unit, key)]

        def writes(address, unit):
            low, high = address & ((1 << PREDECODE_BITS) - 1), address >> PREDECODE_BITS
            return (decoded_bit("write", lambda op: op.valid & op.write, unit)
                    & decoded_bit(f"lo{low}", lambda op: op.addr[:PREDECODE_BITS] == low, unit)
                    & decoded_bit(f"hi{high}", lambda op: op.addr[PREDECODE_BITS:] == high, unit))

        def decoded_compare(fn, bound, above, name, unit):
            """fn(op) > bound (``above``; else < bound) of the access in
            stage wd - 1, like ``decoded``, in two registered levels: the
            halves' comparisons from stage wd - 3, then their combination
            (a 32-bit comparison in one clock was among a 16-channel
            build's late paths, 6.2 ns)."""
            v = fn(at(unit, wd - 3))
            h = len(v) // 2
            parts = {}
            for half, (x, c) in (("hi", (v[h:], bound >> h)), ("lo", (v[:h], bound & ((1 << h) - 1)))):
                strict = Signal(name=f"{name}_{half}_{_unit_tag(unit)}")
                m.d.sync += strict.eq(_strictly(x, c, above))
                parts[half] = strict
            equal = Signal(name=f"{name}_hi_eq_{_unit_tag(unit)}")
            m.d.sync += equal.eq(v[h:] == bound >> h)
            s = Signal(name=f"{name}_{_unit_tag(unit)}")
            m.d.sync += s.eq(parts["hi"] | (equal & parts["lo"]))
            return s

        def clamped_value(reg_name, f, unit):
            """The field's value from the access in stage wd - 1, clamped: the
            comparisons before, in registers (``decoded_compare``), so that
            the clock into the landing register holds only the selection
            (one clock for both was the SDRAM build's critical path, op1 ->
            compare -> select -> LENGTH, docs/bitstream.md)."""
            lo, hi = f.clamp
            field = lambda op: op.data[f.lsb:f.lsb + f.width]
            name = f"{reg_name.lower()}_{f.name}"
            v = field(at(unit, wd - 1))
            if hi < (1 << f.width) - 1:
                v = Mux(decoded_compare(field, hi, True, f"above_{name}", unit), hi, v)
            if lo > 0:
                v = Mux(decoded_compare(field, lo, False, f"below_{name}", unit), lo, v)
            return v
        env.__dict__.update(op=op, stage=stage, unit_of=unit_of, chains=chains, at=at, storage=storage,
                          wd=wd, decoded=decoded, landing=landing, decoded_bits=decoded_bits,
                          decoded_bit=decoded_bit, writes=writes, decoded_compare=decoded_compare,
                          clamped_value=clamped_value)

    def _landing(self, env):
        """The write's landing, register to register: per register its strobe, per
        group of channels (and the global registers) a copy of the data, of the
        clamped field values and of APPLY."""
        m, rmap, at, wd, decoded = env.m, env.rmap, env.at, env.wd, env.decoded
        landing, writes, clamped_value = env.landing, env.writes, env.clamped_value
        apply_addr = rmap.reg("APPLY").addr
        strobe = {}           # register address -> write strobe, landing
        land_data = {}        # channel (None: global) -> the landing data
        land_field = {}       # (register address, field name) -> landing value
        land_apply = {}       # channel (None: global) -> APPLY (bit 0) landing
        next_apply = None     # the global APPLY landing's input: APPLY lands in the next clock
        group_hit = {}        # group (None: global) -> "the access in stage wd - 1 writes it or APPLY"
        units = [(None, [r for r in rmap.registers if r.channel is None])]
        units += [(g, [r for r in rmap.registers if r.channel in members])
                  for g, members in enumerate(self._groups)]
        for g, regs in units:
            tag = _unit_tag(g)
            lo_addr, hi_addr = min(r.addr for r in regs), max(r.addr for r in regs)

            # the address's range compare a clock earlier, into a register of
            # its own (the compares and the access's flags in one clock were a
            # 16-channel build's latest path, 5.5 ns), itself from parts
            # registered a clock before (the 16-bit compare in one clock,
            # four LUT levels, was among the next builds' late paths, 5.2 ns)
            addressed = Signal(name=f"hit_addr_{tag}")
            m.d.sync += addressed.eq(_registered_address_match(
                m, at(g, wd - 4).addr, [(lo_addr, hi_addr), (apply_addr, apply_addr)], f"hit_addr_{tag}"))
            hit = group_hit[g] = decoded(lambda op, addressed=addressed: op.valid & op.write & addressed,
                                         1, "hit", g)
            before = at(g, wd - 1)
            dcopy = landing(Mux(hit, before.data, 0), 32, f"land_data_{tag}", data=True)
            ap_in = writes(apply_addr, g) & before.data[0]
            ap = landing(ap_in, 1, f"land_apply_{tag}")
            if g is None:
                next_apply = ap_in
            group_clamped = {}
            for r in regs:
                suffix = "" if r.channel is None else str(r.channel)
                strobe[r.addr] = landing(writes(r.addr, g), 1, f"w_{r.name.lower()}{suffix}")
                for f in r.fields:
                    if f.access not in STORED:
                        continue
                    if not f.clamp:
                        land_field[(r.addr, f.name)] = dcopy[f.lsb:f.lsb + f.width]
                        continue
                    key = (r.name, f.name)
                    if key not in group_clamped:
                        group_clamped[key] = landing(Mux(hit, clamped_value(r.name, f, g), 0), f.width,
                                                     f"land_{r.name.lower()}_{f.name}_{tag}", data=True)
                    land_field[(r.addr, f.name)] = group_clamped[key]
            for ch in ([None] if g is None else self._groups[g]):
                land_data[ch] = dcopy
                land_apply[ch] = ap
        env.__dict__.update(apply_addr=apply_addr, strobe=strobe, land_data=land_data, land_field=land_field,
                          land_apply=land_apply, next_apply=next_apply, group_hit=group_hit)

    def _storage_writes(self, env):
        """The fields kept in flip-flops, written at their strobes."""
        m, rmap, storage, strobe, land_field = env.m, env.rmap, env.storage, env.strobe, env.land_field
        # Generic rw storage.
        for r in rmap.registers:
            for f in r.fields:
                if (r.name, r.channel, f.name) in storage:
                    with m.If(strobe[r.addr]):
                        m.d.sync += storage[(r.name, r.channel, f.name)].eq(land_field[(r.addr, f.name)])

    def _stream_run(self, env):
        """The stream write path's run since the last STREAM_ADDR write, which a
        SWAP is checked against."""
        m, rmap, c, storage, strobe = env.m, env.rmap, env.c, env.storage, env.strobe
        land_field, land_data = env.land_field, env.land_data
        # The stream write path's run since the last STREAM_ADDR write: its
        # start, words (saturating) and CRC-32 register (zlib's value XOR ones).
        # A SWAP is taken only if the run is the channel's BASE, LENGTH and CRC.
        addr = storage[("STREAM_ADDR", None, "addr")]
        data_w = strobe[rmap.reg("STREAM_DATA").addr]
        run_start = Signal.like(addr, name="run_start")
        run_count = Signal(c.length_width, name="run_count")
        run_crc = Signal(32, init=0xFFFFFFFF, name="run_crc")
        # run_count == its largest value, in a register: the count's
        # saturating increment from its own compare was among the 200 MHz
        # build's late endpoints (run_count -> run_count, 6.5 ns)
        run_full = Signal(name="run_full")
        count_max = (1 << c.length_width) - 1
        start_addr = rmap.reg("STREAM_ADDR").addr
        with m.If(strobe[start_addr]):
            m.d.sync += [run_start.eq(land_field[(start_addr, "addr")]), run_count.eq(0), run_full.eq(0)]
        with m.Elif(data_w):
            m.d.sync += [run_count.eq(run_count + ~run_full),
                         run_full.eq(run_full | (run_count == count_max - 1))]
        _crc_run(m, run_crc, strobe[start_addr], data_w, land_data[None], "run_crc")
        env.__dict__.update(addr=addr, data_w=data_w, run_start=run_start, run_count=run_count,
                          run_crc=run_crc)

    def _slot_rams(self, env):
        """The per-channel fields in distributed RAMs, one per field and group of
        channels, and the engine's read of them by slot."""
        m, platform, rmap, bus, decoded, decoded_bit = env.m, env.platform, env.rmap, env.bus, env.decoded, env.decoded_bit
        landing, land_field, group_hit = env.landing, env.land_field, env.group_hit
        # Per group, RAM_FIELDS in distributed RAMs, one per field, by slot
        # (channel groups[g][s] at s), written in the clock a flip-flop would
        # be. Three kinds of read, each a read port (a copy of the RAM):
        # - the engine's, SLOT_RAM_FIELDS in turn by a slot counter of the
        #   group's own, which counts as the pipeline's does, into one
        #   register per field (``values``);
        # - the read-back's, at the read's slot;
        # - the SWAP check's, BASE, LENGTH and CRC at the CTRL write's slot.
        # Flip-flops for them, selected by slot into the pipelines and by
        # address into the read-back and compared per channel, were most of
        # the router's congestion at 200 MHz (docs/bitstream.md). A RAM is not
        # reset: until a slot's field is written after a reset, its reset
        # value is read (a bit per slot and field says which).
        S = self._slots
        D = max(2, S)            # the RAMs' depth: no zero-width address at one slot
        slot_bits = (D - 1).bit_length()
        base, stride = rmap.channel_base, rmap.channel_stride
        stride_bits = stride.bit_length() - 1
        slot_of = [0] * (1 << (len(bus.addr) - stride_bits))      # by address >> stride_bits
        for members in self._groups:
            for s, ch in enumerate(members):
                slot_of[(base + stride * ch) >> stride_bits] = s

        def slot_at(op):
            return Array(Const(s, slot_bits) for s in slot_of)[op.addr[stride_bits:]]

        def ram_range(members):
            """The addresses of the channel registers of ``members``."""
            return (base + stride * min(members), base + stride * (max(members) + 1) - 1)

        def ram_register(op, members, offset):
            """The access ``op`` is to the register at ``offset`` of one of ``members``."""
            return _within(op.addr, *ram_range(members)) & (op.addr[:stride_bits] == offset)

        def slot_ram(g, members, name, reg_name, field_name, w_en_in, w_slot, w_onehot_in, data_in):
            """Group g's distributed RAM of one per-channel field (channel
            members[s] at slot s), written at the landing (``w_en_in`` and the
            landing slot one-hot a clock ahead, ``w_slot`` and ``data_in`` in
            the landing clock), and the slots unwritten since reset. Returns
            ``(read, fresh, fresh_ahead, reset_of, resets)``: ``read(slot)``
            a read port's word."""
            width = rmap.reg(reg_name, 0).field(field_name).width
            w_en = landing(w_en_in, 1, f"ram_{name}_we_g{g}")
            resets = [0] * D
            for s, ch in enumerate(members):
                resets[s] = rmap.reg(reg_name, ch).field(field_name).reset
            # (a primitive's 16 words, the address bits above the slot's from
            # a flip-flop beside the RAMs: ``local_constant``)
            depth = lut_ram_depth(D)
            mem = Memory(shape=width, depth=depth, init=resets + [0] * (depth - D),
                         attrs={"ram_style": "distributed"})
            m.submodules[f"ram_{name}_g{g}"] = mem
            high_bits = (depth - 1).bit_length() - slot_bits
            high = local_constant(m, platform, 0, high_bits, f"ram_{name}_high_g{g}") if high_bits else None

            def address(slot):
                assert len(Value.cast(slot)) == slot_bits
                return Cat(slot, high) if high is not None else slot
            wp = mem.write_port()
            m.d.comb += [wp.en.eq(w_en), wp.addr.eq(address(w_slot)), wp.data.eq(data_in)]
            # the slots unwritten since reset, and the same a clock ahead,
            # from the landing's inputs (from the landing's registers, the
            # write enable -> the next fresh bits -> the engine's
            # use-reset flag was the 64-channel build's worst path, 7.7 ns)
            fresh = Signal(D, init=(1 << len(members)) - 1, name=f"ram_{name}_fresh_g{g}")
            fresh_ahead = Signal(D, init=(1 << len(members)) - 1, name=f"ram_{name}_fresh_ahead_g{g}")
            m.d.sync += [fresh_ahead.eq(fresh_ahead & ~Mux(w_en_in, w_onehot_in, 0)),
                         fresh.eq(fresh_ahead)]

            def raw_read(slot):
                rp = mem.read_port(domain="comb")
                m.d.comb += rp.addr.eq(address(slot))
                return rp.data
            return raw_read, fresh, fresh_ahead, Array(Const(v, width) for v in resets), resets

        ram_reads = []         # per group: field name -> (fn(slot) -> the RAM's word, fresh bits, reset values)
        unstated = []          # per group: slots whose BASE, LENGTH or CRC is unwritten since reset
        landing_slot = []      # per group: (the landing slot, its one-hot a clock ahead)
        for g, members in enumerate(self._groups):
            # the group's landing decode: APPLY is in it too, but its offset
            # is no RAM field's, so it writes none
            in_group = group_hit[g]
            pre_slot = decoded(slot_at, slot_bits, "pre_slot", g)
            pre_onehot = decoded(lambda op: Array(Const(1 << s, D) for s in slot_of)[op.addr[stride_bits:]],
                                 D, "pre_slot_onehot", g)
            w_slot = landing(Mux(in_group, pre_slot, 0), slot_bits, f"ram_slot_g{g}", data=True)
            w_onehot_in = Mux(in_group, pre_onehot, 0)      # the landing slot, one-hot, a clock ahead
            landing_slot.append((w_slot, w_onehot_in))
            reads, fresh_of = {}, {}
            for name, (reg_name, field_name) in ram_fields(rmap).items():
                offset = rmap.reg(reg_name, 0).addr - base
                width = rmap.reg(reg_name, 0).field(field_name).width
                w_en_in = in_group & decoded_bit(f"off{offset}", lambda op: op.addr[:stride_bits] == offset, g)
                land = land_field[(rmap.reg(reg_name, members[0]).addr, field_name)]
                raw_read, fresh, fresh_ahead, reset_of, resets = slot_ram(
                    g, members, name, reg_name, field_name, w_en_in, w_slot, w_onehot_in, land)
                fresh_of[name] = fresh
                reads[name] = (raw_read, fresh, reset_of)
                if name in slot_ram_fields(rmap):
                    # the engine's: whether the slot read next is unwritten
                    # since reset, and its reset value, a clock ahead, so that
                    # the read's clock holds only the RAM and one selection
                    # (the slot counter, and one a slot ahead, per field:
                    # one pair for the group's four fields, into their RAMs'
                    # reads and the use-reset selections, was the 64-channel
                    # build's latest path, 5.8 ns, 4.4 of it routing)
                    r_slot = Signal(range(D), init=S - 1, name=f"ram_{name}_rslot_g{g}")
                    r_ahead = Signal(range(D), init=0, name=f"ram_{name}_rslot_ahead_g{g}")
                    m.d.sync += [r_slot.eq(r_ahead), r_ahead.eq(Mux(r_ahead == S - 1, 0, r_ahead + 1))]
                    use_reset = Signal(init=len(members) == S, name=f"ram_{name}_use_reset_g{g}")
                    reset_value = Signal(width, init=resets[S - 1], name=f"ram_{name}_reset_g{g}")
                    m.d.sync += [use_reset.eq(fresh_ahead.bit_select(r_ahead, 1)),
                                 reset_value.eq(reset_of[r_ahead]),
                                 self.values[g][name].eq(Mux(use_reset, reset_value, raw_read(r_slot)))]
            ram_reads.append(reads)
            unstated.append(fresh_of["base"] | fresh_of["length"] | fresh_of["crc"])
        env.__dict__.update(S=S, D=D, slot_bits=slot_bits, stride_bits=stride_bits, slot_of=slot_of,
                          slot_at=slot_at, ram_range=ram_range, ram_register=ram_register,
                          slot_ram=slot_ram, ram_reads=ram_reads, unstated=unstated,
                          landing_slot=landing_slot)

    def _swap_check(self, env):
        """The SWAP check: each group compares the stream write path's run with the
        addressed channel's BASE, LENGTH and CRC; a SWAP taken writes PLAYED."""
        m, platform, rmap, N, at = env.m, env.platform, env.rmap, env.N, env.at
        wd, landing, decoded_bit, group_hit, slot_at = env.wd, env.landing, env.decoded_bit, env.group_hit, env.slot_at
        ram_register, ram_reads, unstated, slot_bits, stride_bits = env.ram_register, env.ram_reads, env.unstated, env.slot_bits, env.stride_bits
        run_start, run_count, run_crc, landing_slot, slot_ram = env.run_start, env.run_count, env.run_crc, env.landing_slot, env.slot_ram
        rejected = [Signal(name=f"rejected{l}") for l in range(N)]
        stages = MATCH_STAGES

        # The SWAP check (landings are at least TAKE_SPACING clocks apart, so
        # the values are final MATCH_STAGES + 1 clocks before a CTRL write
        # lands): each group compares the run with BASE, LENGTH and CRC of
        # the slot the write addresses, read at that slot (from the bus,
        # registered), in parts of 8 bits; the group's result, in MATCH_STAGES
        # registered levels, off the path into the command. A slot whose
        # BASE, LENGTH or CRC is unwritten since reset does not match (the
        # RAMs are not reset; the model: ReplayModel.write).
        ctrl_offset = rmap.reg("CTRL", 0).addr - rmap.channel_base

        def equal_parts(a, b, k=8):
            return Cat(*(a[i:i + k] == b[i:i + k] for i in range(0, len(a), k)))
        group_match = []
        for g, members in enumerate(self._groups):
            m_slot = Signal(slot_bits, name=f"match_slot_g{g}")
            m_hit = Signal(name=f"match_hit_g{g}")
            src = at(g, wd - stages - 1)
            m.d.sync += [m_slot.eq(slot_at(src)), m_hit.eq(ram_register(src, members, ctrl_offset))]
            # each field's RAMs read at a copy of the slot of their own (kept:
            # one register for the 18 LUT RAMs was 3.6-4.4 ns of routing into
            # them, the latest path of two- and four-pipeline builds)
            raw = {name: ram_reads[g][name][0](kept_register(m, platform, slot_at(src), f"match_slot_{name}_g{g}"))
                   for name in ("base", "length", "crc")}
            m_hit = m_hit & ~unstated[g].bit_select(m_slot, 1)
            raw = {name: landing(word, len(word), f"match_{name}_g{g}", data=True)
                   for name, word in raw.items()}
            m_hit = landing(m_hit, 1, f"match_hit_r_g{g}")
            # the run in registers of the group's own (kept), a clock before
            # the comparison: the run's one place into every group's
            # comparisons was a latest path at 64 channels (6.1-6.5 ns). The
            # CRC is final a clock before the copy (TAKE_SPACING). The copies
            # take the registers as they are (the CRC's final XOR with ones is
            # on CRC's side of the comparison): logic before them is one
            # logic for all the copies to synthesis, placed beside one group
            # (5.7 ns into another's copy).
            run = kept_register(m, platform, Cat(run_start, run_count, run_crc), f"match_run_g{g}")
            parts = Cat(equal_parts(run[:len(run_start)], raw["base"]),
                        equal_parts(run[len(run_start):-32], raw["length"]),
                        equal_parts(run[-32:], ~raw["crc"]))
            parts = landing(parts, len(parts), f"match_parts_g{g}")
            m_hit = landing(m_hit, 1, f"match_hit_q_g{g}")
            matched = m_hit & parts.all()
            group_match.append(landing(matched, 1, f"match_g{g}"))
            # PLAYED: the CRC of a SWAP taken, into the group's RAM at the
            # CTRL write's landing: the run's CRC (the group's copy, which no
            # access changes until the next landing, TAKE_SPACING later), equal
            # to the channel's CRC where the check matched; the enable from the
            # landing's inputs: the group's CTRL write, its swap bit and the
            # check's result.
            w_slot, w_onehot_in = landing_slot[g]
            before = at(g, wd - 1)
            took = (group_hit[g] & decoded_bit(f"off{ctrl_offset}", lambda op: op.addr[:stride_bits] == ctrl_offset, g)
                    & before.data[rmap.reg("CTRL", 0).field("swap").lsb] & matched)
            raw_read, fresh, _, reset_of, _ = slot_ram(g, members, "played", "PLAYED", "crc", took, w_slot,
                                                       w_onehot_in, ~run[-32:])
            ram_reads[g]["played"] = (raw_read, fresh, reset_of)
        # only the addressed channel's group can match: each channel's command
        # takes its group's result (their OR, one register for every channel,
        # was a latest path of a 16-channel, 100 MS/s build, 6.5 ns)
        match_of = {ch: group_match[g] for g, members in enumerate(self._groups) for ch in members}
        env.__dict__.update(rejected=rejected, match_of=match_of)

    def _follow_switch(self, env):
        """FOLLOW_SWITCH (a block with START): the channel it names switches by
        force, as a disabling CTRL write with a SWAP taken would make it, in
        the first landing clock after the write's whose step number
        (``step_lo``, its low bits) is the one named and follows the write's
        own step. One is held at a time; a write replaces it. From M = 2 the
        match is made a clock ahead and the channel decoded at the write's
        landing, so each channel's flags take it from registers (the match
        and the channel's decode in the landing clock, into every channel's
        flags, were the first following build's latest path, 10.8 ns)."""
        env.follow_fire = env.follow_switch_late = None
        if not env.c.start_frac:
            return
        m, rmap, N = env.m, env.rmap, env.N
        r = rmap.reg("FOLLOW_SWITCH")
        landed, data = env.strobe[r.addr], env.land_data[None]
        ch_f, step_f = r.field("channel"), r.field("step")
        channel, step = data[ch_f.lsb:ch_f.lsb + ch_f.width], data[step_f.lsb:step_f.lsb + step_f.width]
        held, advanced = Signal(name="follow_held"), Signal(name="follow_advanced")
        held_step = Signal(step_f.width, name="follow_held_step")
        held_of = Signal(N, name="follow_held_of")            # the channel, one-hot
        with m.If(landed):
            # (a step in the landing's own period counts as after the write's)
            m.d.sync += [held.eq(1), held_step.eq(step), advanced.eq(self.land_step),
                         held_of.eq(Cat(channel == l for l in range(N)))]
        with m.Elif(self.land_step):
            m.d.sync += advanced.eq(1)
        due = held & advanced & (held_step == self.step_lo)
        if env.c.slots >= 2:          # nothing it reads changes between two landing clocks
            due_q = Signal(name="follow_due")
            m.d.sync += due_q.eq(due)
            due = due_q
        fire = Signal(name="follow_fire")
        m.d.comb += fire.eq(self.land_tick & due & ~landed)
        with m.If(fire):
            m.d.sync += held.eq(0)
        env.follow_fire = [held_of[l] & fire for l in range(N)]
        # a write naming a step half the counter's span or more after its own
        # named one already past: it would switch a counter's span late (STATUS.late)
        env.follow_switch_late = landed & (step - self.step_lo - 1)[step_f.width - 1]

    def _commands(self, env):
        """Per channel: what the engine reads of it from flip-flops, the applied
        tap, and the command a CTRL write leaves for its next visit."""
        m, rmap, N, land_data, land_apply = env.m, env.rmap, env.N, env.land_data, env.land_apply
        storage, strobe, match_of, rejected = env.storage, env.strobe, env.match_of, env.rejected
        # Per channel: what the engine reads, the applied tap, the command.
        taps = []
        for l in range(N):
            ctrl = rmap.reg("CTRL", l)
            rg = self.regs[l]
            d = rmap.reg("DELAY", l)
            lnd = land_data[l]
            tap = Signal(rg.tap.shape(), init=d.fields[0].reset, name=f"tap{l}")
            taps.append(tap)
            with m.If(land_apply[l]):
                m.d.sync += tap.eq(storage[("DELAY", l, "delay")])
            # A CTRL write leaves a command for the channel's next visit; the
            # engine consumes it when it reads the channel (cmd_ack).
            swap = lnd[ctrl.field("swap").lsb]
            enable = lnd[ctrl.field("enable").lsb]
            with m.If(strobe[ctrl.addr]):
                m.d.sync += [rg.force_swap.eq(~enable & swap & match_of[l]), rg.force_pending.eq(~enable),
                             rg.swap_req.eq(swap & match_of[l])]
                with m.If(swap):
                    m.d.sync += rejected[l].eq(~match_of[l])
            if env.follow_fire is not None:
                with m.Elif(env.follow_fire[l]):
                    m.d.sync += [rg.force_swap.eq(1), rg.force_pending.eq(0), rg.swap_req.eq(0)]
            with m.Elif(self.cmd_ack[l]):
                m.d.sync += [rg.force_swap.eq(0), rg.force_pending.eq(0), rg.swap_req.eq(0)]
            m.d.comb += [rg.enable.eq(storage[("CTRL", l, "enable")]), rg.tap.eq(tap)]
        env.__dict__.update(taps=taps)

    def _common_delay(self, env):
        """The common delay that applies from the next clock."""
        m, rmap, storage, strobe, land_field = env.m, env.rmap, env.storage, env.strobe, env.land_field
        next_apply = env.next_apply
        # The common delay that applies from the next clock, in a register:
        # from APPLY's landing input, a clock before it lands, and the value
        # COMMON_DELAY holds in the next clock (from APPLY's landing
        # register it was a latest path of the two-pipeline build, into the
        # common line's read address, 6.3-6.5 ns).
        common = rmap.reg("COMMON_DELAY")
        stored_cd = storage[("COMMON_DELAY", None, "delay")]
        next_cd = Mux(strobe[common.addr], land_field[(common.addr, "delay")], stored_cd)   # stored_cd's next
        applies = Signal(self._cw, init=common.fields[0].reset, name="common_delay_next")
        m.d.sync += applies.eq(Mux(next_apply, next_cd, applies))
        m.d.comb += self.common_delay_next.eq(applies)
        env.__dict__.update(applies=applies)

    def _pool_write(self, env):
        """The pool's write port, registered."""
        m, data_w, addr, land_data = env.m, env.data_w, env.addr, env.land_data
        # Pool write path, registered.
        m.d.sync += self.wr_en.eq(data_w)
        wr_data = Signal.like(self.wr_data, name="wr_data_q", reset_less=True)     # read under wr_en
        m.d.comb += self.wr_data.eq(wr_data)
        with m.If(data_w):
            m.d.sync += [self.wr_addr.eq(addr), wr_data.eq(land_data[None]), addr.eq(addr + 1)]

    def _status(self, env):
        """The sticky status flags, cleared by the read of STATUS that reports them."""
        m, rmap, stage = env.m, env.rmap, env.stage
        # Sticky overflow: a read of STATUS samples it at status_delay and
        # clears what it reported (a saturation in that cycle stays set).
        status = rmap.reg("STATUS")
        flag = self.overflow
        st = stage[self._status_delay]
        clear = Signal()
        m.d.comb += clear.eq(st.valid & ~st.write & (st.addr == status.addr))
        m.d.sync += flag.eq(Mux(clear, 0, flag) | self.overflow_set)
        m.d.sync += self.underflow.eq(Mux(clear, 0, self.underflow) | self.underflow_set)
        env.__dict__.update(flag=flag)

    def _scan(self, env):
        """The antenna scan's settings, its restart and the pattern table's write
        path with its CRC (a block built with the scan)."""
        m, rmap, storage, strobe, land_data = env.m, env.rmap, env.storage, env.strobe, env.land_data
        if not rmap.contract.scan:
            return
        ctrl = rmap.reg("SCAN_CTRL")
        # the restart in a register of its own, landing with the write (the
        # strobe and the data's bit ANDed into the generator's state was the
        # scan build's latest path at seed 2 of 73bb311, 6.4 ns)
        restart = env.landing(env.writes(ctrl.addr, None)
                              & env.at(None, env.wd - 1).data[SCAN_RESTART.bit_length() - 1], 1, "scan_restart")
        for name in ("mode", "anticlockwise", "auto", "acp_log2"):
            m.d.comb += self.scan[name].eq(storage[("SCAN_CTRL", None, name)])
        m.d.comb += [self.scan.period.eq(storage[("SCAN_PERIOD", None, "samples")]),
                     self.scan.start.eq(storage[("SCAN_START", None, "azimuth")]),
                     self.scan_restart.eq(restart),
                     self.pattern_shift.eq(storage[("PATTERN", None, "shift")]),
                     self.pattern_floor.eq(storage[("PATTERN", None, "floor")])]
        # the table's write path, registered, as the pool's (``_pool_write``)
        addr = storage[("PATTERN_ADDR", None, "addr")]
        word_w = strobe[rmap.reg("PATTERN_DATA").addr]
        word = land_data[None][:PATTERN_WIDTH]
        m.d.sync += self.pattern_w_en.eq(word_w)
        with m.If(word_w):
            m.d.sync += [self.pattern_w_addr.eq(addr), self.pattern_w_data.eq(word), addr.eq(addr + 1)]
        pattern_crc = Signal(32, init=0xFFFFFFFF, name="pattern_crc")
        _crc_run(m, pattern_crc, strobe[rmap.reg("PATTERN_ADDR").addr], word_w, word, "pattern_crc")
        env.pattern_crc = pattern_crc

    def _follow(self, env):
        """Channels that follow the beam: the settings, the start, the turbine
        table's write path and its CRC, the sticky late and overrun flags."""
        env.table_crc = None
        m, rmap, storage, strobe, land_data = env.m, env.rmap, env.storage, env.strobe, env.land_data
        if not rmap.contract.follow_rows:
            return
        ctrl = rmap.reg("FOLLOW_CTRL")
        start = env.landing(env.writes(ctrl.addr, None)
                            & env.at(None, env.wd - 1).data[ctrl.field("start").lsb], 1, "follow_start")
        m.d.comb += [self.follow_on.eq(storage[("FOLLOW_CTRL", None, "on")]), self.follow_start.eq(start),
                     self.follow.rows.eq(storage[("FOLLOW_CTRL", None, "rows")]),
                     self.follow.entry_off.eq(storage[("FOLLOW_WINDOW", None, "entry_off")]),
                     self.follow.exit_off.eq(storage[("FOLLOW_WINDOW", None, "exit_off")]),
                     self.follow.width.eq(storage[("FOLLOW_SPAN", None, "width")]),
                     self.follow.guard.eq(storage[("FOLLOW_SPAN", None, "guard")])]
        addr = storage[("TABLE_ADDR", None, "addr")]
        word_w = strobe[rmap.reg("TABLE_DATA").addr]
        m.d.sync += self.table_w_en.eq(word_w)
        with m.If(word_w):
            m.d.sync += [self.table_w_addr.eq(addr), self.table_w_data.eq(land_data[None]), addr.eq(addr + 1)]
        env.table_crc = table_crc = Signal(32, init=0xFFFFFFFF, name="table_crc")
        _crc_run(m, table_crc, strobe[rmap.reg("TABLE_ADDR").addr], word_w, land_data[None], "table_crc")
        # sticky until the STATUS read that reports them (as the overflow)
        st = env.stage[self._status_delay]
        clear = st.valid & ~st.write & (st.addr == rmap.reg("STATUS").addr)
        env.follow_late, env.follow_overrun = Signal(name="follow_late"), Signal(name="follow_overrun")
        m.d.sync += [env.follow_late.eq(Mux(clear, 0, env.follow_late) | self.follow_late_set
                                        | env.follow_switch_late),
                     env.follow_overrun.eq(Mux(clear, 0, env.follow_overrun) | self.follow_overrun_set)]

    def _read_back(self, env):
        """The read-back: three parts, each sampled at its own stage, each a
        registered selection over the registers, ORed."""
        m, platform, rmap, bus, N = env.m, env.platform, env.rmap, env.bus, env.N
        stage, at, wd, decoded, landing = env.stage, env.at, env.wd, env.decoded, env.landing
        storage, strobe, land_data, addr, run_crc = env.storage, env.strobe, env.land_data, env.addr, env.run_crc
        run_count, rejected, taps, applies, flag = env.run_count, env.rejected, env.taps, env.applies, env.flag
        ram_reads, slot_at, ram_range, stride_bits, unit_of = env.ram_reads, env.slot_at, env.ram_range, env.stride_bits, env.unit_of
        # Read-back: three parts, each sampled at its own stage, each a
        # registered selection over the registers (SELECT_LEVELS levels), ORed.
        hooks_mirror, hooks_status = {}, {("STATUS", None, "overflow"): flag,
                                          ("STATUS", None, "underflow"): self.underflow}
        for l in range(N):
            hooks_mirror[("CTRL", l, "swap")] = self.pending[l]
            hooks_mirror[("CTRL", l, "bank")] = self.bank[l]

        def word_of(r, pick):
            word = Const(0, 32)
            any_bit = False
            for f in r.fields:
                v = pick((r.name, r.channel, f.name), f)
                if v is not None:
                    word = word | (v.as_unsigned() << f.lsb)
                    any_bit = True
            return word[:32] if any_bit else None

        hooks_stored = {("STREAM_CRC", None, "crc"): ~run_crc, ("STREAM_COUNT", None, "count"): run_count}
        if rmap.has("POOL_CHECK"):
            # The SDRAM pool's read-back (PoolReadCheck): started the clock
            # after its write lands, from the STREAM_ADDR stored then; busy
            # from that clock on, so that no read after the write misses it.
            check = rmap.reg("POOL_CHECK")
            m.d.sync += self.check_start.eq(strobe[check.addr])
            with m.If(strobe[check.addr]):
                words = check.field("words")
                m.d.sync += [self.check_addr.eq(addr),
                             self.check_words.eq(land_data[None][words.lsb:words.lsb + words.width])]
            hooks_stored[("POOL_CHECK", None, "busy")] = self.check_busy | self.check_start
            hooks_stored[("POOL_CHECK_CRC", None, "crc")] = self.check_crc
        for l in range(N):
            hooks_stored[("CTRL", l, "rejected")] = rejected[l]
            hooks_stored[("DELAY", l, "applied")] = taps[l]
        hooks_stored[("COMMON_DELAY", None, "applied")] = applies
        if env.table_crc is not None:
            hooks_stored[("TABLE_CRC", None, "crc")] = ~env.table_crc
            hooks_status[("STATUS", None, "late")] = env.follow_late
            hooks_status[("STATUS", None, "overrun")] = env.follow_overrun
        hooks_scan = {}
        if rmap.contract.scan:
            hooks_stored[("PATTERN_CRC", None, "crc")] = ~env.pattern_crc
            hooks_scan = {("SCAN_STATUS", None, "beam"): self.scan_beam,
                          ("SCAN_STATUS", None, "learned"): self.scan_learned,
                          ("ACP_PER_REV", None, "count"): self.scan_per_rev,
                          ("STATUS", None, "arp_lost"): self.scan_lost}

        def stored(key, f):
            if key in storage and f.access == "rw":
                return storage[key]
            if key in hooks_stored:
                return hooks_stored[key]
            if (f.access == "ro" and key not in hooks_mirror and key not in hooks_status and key not in hooks_scan
                    and (key[0], key[2]) not in read_back_ram(rmap).values()):
                return Const(f.reset, f.width)
            return None

        parts = [(wd, stored),
                 (self._mirror_delay, lambda key, f: hooks_mirror.get(key)),
                 (self._status_delay, lambda key, f: hooks_status.get(key)),
                 (self._scan_delay, lambda key, f: hooks_scan.get(key))]
        # RAM_FIELDS read back from their group's RAMs at the read's slot
        # (from the stage before, registered), sampled with the stored values:
        # the RAM's word, or the reset value while the slot's field is
        # unwritten since reset. The RAM is read two clocks before the
        # sampling point: the access before the read was taken TAKE_SPACING
        # clocks or more earlier and has landed by then, so the word is the
        # one the stored values show at the sampling point. The RAM's word,
        # the fresh bit and the reset value are registered, then selected
        # into a register. (The RAM's read port and the selection in one
        # clock were the 200 MHz build's worst path at seed 2, 7.4 ns; read
        # into one register, 6.7 ns.)
        # The read's slot in a register (kept) for each field and part: one
        # per group, into the fresh bits', the reset values' and the RAMs'
        # selections of all fields, was the 64-channel build's latest path
        # (rd_slot -> a fresh bit, 5.8-5.9 ns).
        early = 2
        ram_words = []
        for g, members in enumerate(self._groups):
            rd_slot_of = slot_at(at(g, wd - 1 - early))
            # the access is to the group's channel registers, a clock before
            # each field's hit (the range compare and the offset's in one
            # clock were among the 64-channel build's late paths, 6.2 ns)
            in_ram = decoded(lambda op, members=members: _within(op.addr, *ram_range(members)), 1, "rd_in_ram", g)
            for name, (reg_name, field_name) in read_back_ram(rmap).items():
                f = rmap.reg(reg_name, 0).field(field_name)
                offset = rmap.reg(reg_name, 0).addr - rmap.channel_base
                raw_read, fresh, reset_of = ram_reads[g][name]
                rd_slot = {what: kept_register(m, platform, rd_slot_of, f"rd_slot_{name}_{what}_g{g}")
                           for what in ("use_reset", "reset", "ram")}
                # data, read out only under the read's hit (reset): no reset
                # (the reset global into ``rd_gain_g1``'s logic was the latest
                # path of the 64-channel build at seed 3, 6.7 ns)
                parts_of = [landing(v, Value.cast(v).shape(), f"rd_{name}_{what}_g{g}", data=True)
                            for v, what in zip((fresh.bit_select(rd_slot["use_reset"], 1),
                                                reset_of[rd_slot["reset"]], raw_read(rd_slot["ram"])),
                                               ("use_reset", "reset", "ram"))]
                word = Mux(*parts_of)
                word = landing(word, word.shape(), f"rd_{name}_g{g}", data=True)
                ram_words.append((f"{name}_g{g}", g,
                                  lambda op, in_ram=in_ram, offset=offset: in_ram & (op.addr[:stride_bits] == offset),
                                  (word.as_unsigned() << f.lsb)[:32]))
        end = self.read_latency - 1
        results = []
        for delay, pick in parts:
            words = [(f"{r.addr:x}", unit_of.get(r.channel), r.addr, word_of(r, pick)) for r in rmap.registers]
            words = [item for item in words if item[3] is not None]
            if delay == wd:
                words += ram_words
            if not words:
                continue
            results.append(self._select(m, at, delay, words, end))
        # Each selection is zero unless its access is a read (``_select``), so
        # the answer is their OR: the stage's flags gating all 32 bits here
        # were the latest path of a two-pipeline build (6.3 ns, 4.9 routing).
        m.d.sync += [bus.r_valid.eq(stage[end].valid & ~stage[end].write),
                     bus.r_data.eq(_or(results) if results else 0)]

    def _select(self, m, at, delay, words, end):
        """The word of the register a read addresses, sampled at stage
        ``delay``: per group of channels (and the global registers), its
        registers selected in groups into registers at that stage, then
        ORed into a register; the groups' words ORed into registers, four
        groups to one, then all ORed into a register, and delayed to stage
        ``end`` (SELECT_LEVELS registered levels). 0 when the access is no
        read or addresses none of ``words`` ((name, unit, reads, word) each,
        ``reads`` the word's address or fn(op): the access is of this word;
        ``at(unit, k)``: stage k as the word's group of channels sees it).
        The selected words' registers have no reset: the bus takes them only
        under ``r_valid``, and the hits that select them are reset."""
        group = 8            # 16 words ORed into a register: 6.5 ns at 16 channels, 100 MS/s
        predecoded = {}

        def predecode(unit, part, value):
            """A part of the address (``"lo"``: its low PREDECODE_BITS; ``"hi"``:
            the rest) equal to ``value`` at stage ``delay - 3``, registered."""
            key = (unit, part, value)
            if key not in predecoded:
                addr = at(unit, delay - 3).addr
                bits = addr[:PREDECODE_BITS] if part == "lo" else addr[PREDECODE_BITS:]
                r = Signal(name=f"rd{delay}_{part}{value}_{_unit_tag(unit)}")
                m.d.sync += r.eq(bits == value)
                predecoded[key] = r
            return predecoded[key]

        by_unit = {}
        for item in words:
            by_unit.setdefault(item[1], []).append(item)
        per_unit = []
        for unit, unit_words in by_unit.items():
            tag = _unit_tag(unit)
            firsts = []
            for g in range(0, len(unit_words), group):
                v = Signal(32, name=f"rd{delay}_{tag}_{g // group}", reset_less=True)
                sel = Const(0, 32)
                for name, _, reads, w in unit_words[g:g + group]:
                    # the address compare a clock earlier, in a register (the
                    # compare and the selection in one clock were the
                    # one-pipeline build's worst path at 7.8 ns)
                    hit = Signal(name=f"rd{delay}_hit_{name}")
                    if isinstance(reads, int) and delay >= 2:
                        # a register's address compared a clock earlier still,
                        # into a register of its own (the 16-bit compare and the
                        # access's flags in one clock were late at 64 channels);
                        # from delay 3 on, from predecoded parts a clock earlier
                        # again (the whole compare, every stage address bit
                        # into a hundred of them, was late at 16 channels, 5.6 ns)
                        addressed = Signal(name=f"rd{delay}_at_{name}")
                        if delay >= 3:
                            m.d.sync += addressed.eq(
                                predecode(unit, "lo", reads & ((1 << PREDECODE_BITS) - 1))
                                & predecode(unit, "hi", reads >> PREDECODE_BITS))
                        else:
                            m.d.sync += addressed.eq(at(unit, delay - 2).addr == reads)
                        op = at(unit, delay - 1)
                        m.d.sync += hit.eq(addressed & op.valid & ~op.write)
                    elif delay >= 1:
                        op = at(unit, delay - 1)
                        m.d.sync += hit.eq(_reads(reads, op) & op.valid & ~op.write)
                    else:
                        op = at(None, 0)
                        m.d.comb += hit.eq(_reads(reads, op) & op.valid & ~op.write)
                    sel = sel | Mux(hit, w, 0)
                m.d.sync += v.eq(sel)
                firsts.append(v)
            # a group's words, then all groups' (all first-level registers
            # ORed into one was a latest path of the 64-channel build, about
            # 75 of them, 6.3 ns)
            u = Signal(32, name=f"rd{delay}_{tag}", reset_less=True)
            m.d.sync += u.eq(_or(firsts))
            per_unit.append(u)
        # four groups' words to a register, then all (all groups' words
        # into one register was late in all three seeds of a 16-channel
        # build, 5.2-5.6 ns)
        quads = []
        for q in range(0, len(per_unit), 4):
            v = Signal(32, name=f"rd{delay}_q{q // 4}", reset_less=True)
            m.d.sync += v.eq(_or(per_unit[q:q + 4]))
            quads.append(v)
        out = Signal(32, name=f"rd{delay}_all", reset_less=True)
        m.d.sync += out.eq(_or(quads))
        for k in range(delay + self.SELECT_LEVELS, end):
            nxt = Signal(32, name=f"rd{delay}_d{k}", reset_less=True)
            m.d.sync += nxt.eq(out)
            out = nxt
        return out


def _crc_run(m, crc, restart, word_strobe, word, name):
    """The CRC-32 register ``crc`` (zlib's value XOR ones) over the words
    landed at ``word_strobe`` since ``restart``: the landing clock loads the
    word into a shift register, the CRC then takes CRC_CLOCKS clocks,
    32 / CRC_CLOCKS bits a clock (complete before the next access lands)."""
    k = CRC_CLOCKS
    b = 32 // k
    rest = Signal(32, name=f"{name}_rest")
    left = Signal(range(k + 1), name=f"{name}_left")
    with m.If(restart):
        m.d.sync += crc.eq(0xFFFFFFFF)
    with m.Elif(word_strobe):
        m.d.sync += [rest.eq(word), left.eq(k)]
    with m.Elif(left != 0):
        m.d.sync += [crc.eq(crc32_step(crc, rest[:b])), rest.eq(rest[b:]), left.eq(left - 1)]


def _reads(reads, op):
    """The access ``op`` is of a word: ``reads`` its address, or fn(op)."""
    return op.addr == reads if isinstance(reads, int) else reads(op)


def _unit_tag(unit):
    """The name tag of a group of channels' signals (None: the global registers')."""
    return "glob" if unit is None else f"g{unit}"


def _registered_address_match(m, addr, ranges, name):
    """Whether ``addr`` lies in one of ``ranges`` (inclusive ``(lo, hi)``
    pairs), from parts registered a clock before: per range, the bits above
    the highest bit in which lo and hi differ compared with theirs, and the
    bits from that one down with the range (the group's registers are an
    aligned block: its low bits' compare is with a constant range of four
    bits at two slots per group). Left after the registers: an AND per
    range and their OR."""
    terms = []
    for k, (lo, hi) in enumerate(ranges):
        split = (lo ^ hi).bit_length()
        top = Signal(name=f"{name}_top{k}")
        m.d.sync += top.eq(addr[split:] == lo >> split if split < len(addr) else 1)
        mask = (1 << split) - 1
        if split:
            low = Signal(name=f"{name}_low{k}")
            m.d.sync += low.eq(_within(addr[:split], lo & mask, hi & mask))
            terms.append(top & low)
        else:
            terms.append(top)
    return Cat(*terms).any()


def _within(addr, lo, hi):
    """``lo <= addr <= hi``, without a comparison the address's width makes
    constant (Verilator's lint refuses those)."""
    inside = Const(1)
    if lo > 0:
        inside = inside & (addr >= lo)
    if hi < (1 << len(addr)) - 1:
        inside = inside & (addr <= hi)
    return inside


def _strictly(x, c, above):
    """``x > c`` (``above``) or ``x < c`` of an unsigned ``x`` and a constant in
    its range, 0 where the width makes it constant (Verilator's lint refuses
    such comparisons)."""
    if above:
        return x > c if c < (1 << len(x)) - 1 else Const(0)
    return x < c if c > 0 else Const(0)


def _or(values):
    acc = values[0]
    for v in values[1:]:
        acc = acc | v
    return acc
