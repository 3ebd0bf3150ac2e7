"""The replay block's register map, described once.

The Amaranth register file (``rast.hdl.registers``), the bit-exact model
(``rast.model.contract.datapath``), the host side (``rast.model.contract.loadplan``) and
``docs/registers.md`` (``rast.model.contract.regdoc``) are all generated from
:func:`register_map`. Plain Python, no Amaranth.

Bus: word addresses, 32-bit data, one access per clock, read data registered
(available the cycle after the read strobe).

Access kinds of a field:

``rw``  storage, reads back what was written (after clamping, see ``clamp``)
``w``   storage the block uses, not read back (reads as 0): kept out of the
        read-back multiplexer, whose size is a routing cost
``ro``  read-only, driven by the hardware
``wo``  write strobe (command); reads as 0 unless a read meaning is given
``rc``  sticky status, cleared by a read of its register
"""

import zlib
from dataclasses import dataclass, field

import numpy as np

from rast.model.contract.fixedpoint import (ReplayContract, STREAM_WIDTH, GAIN_WIDTH, PHASE_FRAC_BITS,
                                            INTERPOLATIONS)
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.scan import (AZIMUTH_BITS, PATTERN_INDEX_BITS, PATTERN_WIDTH, MAX_PATTERN_SHIFT,
                                      ACP_MIN_LEARN, AZIMUTH_CODES)

__all__ = ["Field", "Register", "RegisterMap", "register_map", "ID_VALUE", "CHANNEL_BASE",
           "CHANNEL_STRIDE", "SCAN_CHANNEL_BASE", "SCAN_CHANNEL_STRIDE", "SCAN_RESTART", "FOLLOW_SWITCH_STEP_BITS", "follow_switch_word", "CTRL_ENABLE", "CTRL_SWAP", "CTRL_BANK", "CTRL_REJECTED", "STORED",
           "CRC32_POLY", "stream_crc32", "APPLIED_LSB"]

ID_VALUE = 0x52415354          # "RAST"
CHANNEL_BASE = 0x10
CHANNEL_STRIDE = 8
#: With the antenna scan the channels' blocks are 16 registers (AZIMUTH is
#: the ninth) from 0x20 on, the scan's registers at 0x10..0x1F.
SCAN_CHANNEL_BASE = 0x20
SCAN_CHANNEL_STRIDE = 16
#: SCAN_CTRL's command bit: restart the beam (free: at SCAN_START; acp: the
#: count, the code and what was learned cleared).
SCAN_RESTART = 1 << 31
#: Low bits of the step number FOLLOW_SWITCH names (a switch up to 4096 steps ahead).
FOLLOW_SWITCH_STEP_BITS = 12
CTRL_ENABLE = 1 << 0
CTRL_SWAP = 1 << 1
CTRL_BANK = 1 << 2
CTRL_REJECTED = 1 << 3
#: Access kinds the register file keeps in storage.
STORED = ("rw", "w")
#: CRC-32 of IEEE 802.3 / zlib, reflected polynomial (the gateware derives its update from it).
CRC32_POLY = 0xEDB88320
#: Bit of COMMON_DELAY and DELAY[l] where the value in effect (``applied``) is read.
APPLIED_LSB = 16


def stream_crc32(words, crc: int = 0) -> int:
    """CRC-32 (zlib's) of stream words as the pool holds them: each 32-bit
    word (I low, Q high) as four bytes, least significant first; ``crc``
    continues an earlier value. This is what CH[l].CRC must hold for a switch."""
    w = np.asarray(words)
    if w.dtype != np.dtype("<u4"):              # packed words (uint32) are taken as they are
        w = (w.astype(np.int64) & 0xFFFFFFFF).astype("<u4")
    return zlib.crc32(np.ascontiguousarray(w).data, crc)


@dataclass(frozen=True)
class Field:
    name: str
    lsb: int
    width: int
    access: str
    reset: int = 0
    doc: str = ""
    #: For rw fields: (lo, hi) the written value is clamped into.
    clamp: tuple | None = None

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.lsb


@dataclass(frozen=True)
class Register:
    name: str
    addr: int
    fields: tuple
    doc: str = ""
    channel: int | None = None

    def field(self, name) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(name)


@dataclass
class RegisterMap:
    contract: ReplayContract
    registers: list = field(default_factory=list)

    def __post_init__(self):
        self._by_key = {(r.name, r.channel): r for r in self.registers}
        self._by_addr = {r.addr: r for r in self.registers}

    @property
    def channel_base(self) -> int:
        """Address of channel 0's block."""
        return SCAN_CHANNEL_BASE if self.contract.scan else CHANNEL_BASE

    @property
    def channel_stride(self) -> int:
        """Addresses between two channels' blocks (a power of two)."""
        return SCAN_CHANNEL_STRIDE if self.contract.scan else CHANNEL_STRIDE

    @property
    def addr_width(self) -> int:
        return max(r.addr for r in self.registers).bit_length()

    def reg(self, name, channel=None) -> Register:
        try:
            return self._by_key[(name, channel)]
        except KeyError:
            raise KeyError(f"No register {name!r} for channel {channel!r}") from None

    def addr(self, name, channel=None) -> int:
        return self.reg(name, channel).addr

    def has(self, name, channel=None) -> bool:
        return (name, channel) in self._by_key

    def by_addr(self, addr) -> Register | None:
        return self._by_addr.get(addr)


def follow_switch_word(rmap: "RegisterMap", channel: int, step: int) -> int:
    """FOLLOW_SWITCH's word: switch ``channel`` at step number ``step`` (its
    low FOLLOW_SWITCH_STEP_BITS bits)."""
    f = rmap.reg("FOLLOW_SWITCH").field("step")
    return channel | (step % (1 << f.width)) << f.lsb


def _bits(n: int) -> int:
    return max(1, int(n).bit_length())


def register_map(contract: ReplayContract, inits=None, common_delay: int = 0) -> RegisterMap:
    """The register map of a replay block built with ``contract``.

    ``inits`` (a list of :class:`ChannelInit`, one per channel or fewer) sets
    the reset values of the per-channel registers, ``common_delay`` that of
    COMMON_DELAY (clamped to ``max_delay``).
    """
    c = contract
    inits = list(inits or [])
    inits += [ChannelInit()] * (c.channels - len(inits))
    interp_code = INTERPOLATIONS.index(c.interpolation)
    config = ((c.channels & 0xFF) | (interp_code << 8) | (int(c.cmult_form == "3mult") << 10)
              | (int(c.pool == "sdram") << 11) | (int(c.scan) << 12) | (c.channels >> 8 << 13) | (c.slots << 16)
              | (int(c.start_frac) << 23))
    regs = [
        Register("ID", 0x00, (Field("id", 0, 32, "ro", ID_VALUE, "constant 0x52415354 ('RAST')"),),
                 "identification"),
        Register("CONFIG", 0x01, (Field("channels", 0, 8, "ro", c.channels & 0xFF,
                                        "channel count N, its low 8 bits (bits 15:13, channels_hi, hold "
                                        "the rest in a build of more than 255 channels)"),
                                  Field("interpolation", 8, 2, "ro", interp_code,
                                        "stream interpolation: 0 hold, 1 linear, 2 FIR"),
                                  Field("cmult3", 10, 1, "ro", int(c.cmult_form == "3mult"),
                                        "1: 3-multiplier complex product"),
                                  Field("sdram", 11, 1, "ro", int(c.pool == "sdram"),
                                        "1: the stream pool is in SDRAM (POOL_WORDS of it)"),
                                  Field("scan", 12, 1, "ro", int(c.scan),
                                        "1: the antenna scan is built in (registers 0x10..0x1F, "
                                        "AZIMUTH; channels from 0x20, 16 apart)"),
                                  # (only where N > 255: the other builds' map as before)
                                  *([Field("channels_hi", 13, 3, "ro", c.channels >> 8,
                                           "channel count N, bits 10:8 (N = channels + 256 * channels_hi)")]
                                    if c.channels > 255 else []),
                                  Field("slots", 16, 7, "ro", c.slots,
                                        "M: fabric clocks per sample, channels per pipeline"),
                                  # (only where the channels have START: the other builds' map as before)
                                  *([Field("start_frac", 23, 1, "ro", 1,
                                           "1: each channel has START (streams start inside a word)")]
                                    if c.start_frac else [])),
                 f"elaboration parameters (reads {config:#x} here)"),
        Register("LATENCY", 0x02, (Field("latency", 0, 16, "ro", c.latency,
                                         "fixed latency L in samples"),),
                 "echo of channel l appears L + COMMON_DELAY + DELAY[l] samples after its input"),
        Register("STATUS", 0x03, (Field("overflow", 0, 1, "rc", 0,
                                        "an output sample saturated since the last read"),
                                  Field("underflow", 1, 1, "rc", 0,
                                        "a channel read a stream word that had not arrived from the pool "
                                        "since the last read (SDRAM pool: a fetch later than the "
                                        "contract's bound; never with block RAM)"),
                                  *((Field("arp_lost", 2, 1, "ro", 0,
                                           "the scan follows the radar and an ARP was missed (an ACP "
                                           "past the revolution's count): the beam keeps turning at "
                                           "the count in use; cleared by the next ARP"),) if c.scan else ()),
                                  *((Field("late", 3, 1, "rc", 0,
                                           "a following channel's load landed after its turbine's guard, or "
                                           "named a step already past, since the last read"),
                                     Field("overrun", 4, 1, "rc", 0,
                                           "a turbine entering found every channel held (more turbines in "
                                           "the window than channels) since the last read"))
                                    if c.follow_rows else ())),
                 "sticky status, cleared by reading"),
        Register("APPLY", 0x04, (Field("delays", 0, 1, "wo", 0,
                                       "write 1: COMMON_DELAY and all channels' DELAY take effect in the same sample"),),
                 "commands"),
        Register("COMMON_DELAY", 0x05, (Field("delay", 0, _bits(c.max_delay), "rw",
                                              min(max(int(common_delay), 0), c.max_delay),
                                              "delay of the line all channels share, samples "
                                              f"(0..{c.max_delay}), takes effect on APPLY",
                                              clamp=(0, c.max_delay)),
                                        Field("applied", APPLIED_LSB, _bits(c.max_delay), "ro",
                                              min(max(int(common_delay), 0), c.max_delay),
                                              "the common delay in effect (the last APPLY's)")),
                 "common delay: up to the nearest turbine"),
        Register("STREAM_ADDR", 0x06, (Field("addr", 0, c.pool_address_width, "rw", 0,
                                             "pool word address; +1 (mod pool) after each STREAM_DATA"),),
                 "stream write path: address"),
        Register("STREAM_DATA", 0x07, (Field("data", 0, 2 * STREAM_WIDTH, "wo", 0,
                                             "stream word, I low, Q high, written to the pool at "
                                             "STREAM_ADDR (any word: the host keeps playing "
                                             "streams' words untouched)"),),
                 "stream write path: data"),
        Register("POOL_WORDS", 0x08, (Field("words", 0, 32, "ro", c.pool_words,
                                            "words of the stream pool"),),
                 "capability"),
        Register("MAX_DELAY", 0x09, (Field("max", 0, 32, "ro", c.max_delay, "largest COMMON_DELAY"),),
                 "capability"),
        Register("MAX_TAP", 0x0A, (Field("max", 0, 32, "ro", c.max_tap,
                                         "largest DELAY (tap) of a channel"),),
                 "capability"),
        Register("SAMPLE_RATE", 0x0B, (Field("hz", 0, 32, "ro", c.sample_rate_hz,
                                             "RTS sample rate the block was built for, Hz "
                                             "(0: not stated)"),),
                 "capability: a manifest for another rate plays every Doppler and range wrong"),
        Register("STREAM_CRC", 0x0C, (Field("crc", 0, 32, "ro", 0,
                                            "CRC-32 of the STREAM_DATA words written since the last "
                                            "STREAM_ADDR write (0 before any)"),),
                 "stream write path: what a switch is checked against"),
        Register("STREAM_COUNT", 0x0D, (Field("count", 0, c.length_width, "ro", 0,
                                              "STREAM_DATA words written since the last STREAM_ADDR "
                                              "write (stops at the field's largest value)"),),
                 "stream write path: what a switch is checked against"),
    ]
    if c.pool == "sdram":
        regs += [
            Register("POOL_CHECK", 0x0E, (
                Field("words", 0, c.length_width, "wo", 0,
                      "write N: read N words back from the pool, from STREAM_ADDR on, into "
                      "POOL_CHECK_CRC"),
                Field("busy", 31, 1, "ro", 0, "1 while the read-back runs")),
                "stream pool read-back (SDRAM pool): what the SDRAM holds, not what arrived"),
            Register("POOL_CHECK_CRC", 0x0F, (Field("crc", 0, 32, "ro", 0,
                                                    "CRC-32 of the words the last POOL_CHECK read back "
                                                    "(valid once busy reads 0)"),),
                     "stream pool read-back (SDRAM pool)"),
        ]
    if c.scan:
        regs += _scan_registers()
    if c.start_frac:
        regs.append(Register("FOLLOW_SWITCH", 0x19, (
            Field("channel", 0, 11, "wo", 0, "the channel to switch to its BASE/LENGTH/PHASE_INC/START"),
            Field("step", 16, FOLLOW_SWITCH_STEP_BITS, "wo", 0,
                  "at the first step after this write's whose number (steps since reset) has these low bits")),
            "a switch by force at a named step, unchecked (channels that follow the beam, "
            "docs/beam_following.md); a second write replaces one not yet taken"))
    if c.follow_rows:
        regs += _follow_registers(c)
    channel_base, stride = (SCAN_CHANNEL_BASE, SCAN_CHANNEL_STRIDE) if c.scan else (CHANNEL_BASE, CHANNEL_STRIDE)
    for ch in range(c.channels):
        base = channel_base + stride * ch
        ini = inits[ch]
        maxd = c.max_tap
        regs += [
            Register("CTRL", base + 0, (
                Field("enable", 0, 1, "rw", int(ini.enable), "channel contributes to the sum; "
                      "written before input k, from output k"),
                Field("swap", 1, 1, "wo", 0,
                      "write 1: switch to BASE/LENGTH/PHASE_INC at the next period boundary (at once "
                      "if the write leaves the channel disabled); reads 1 while pending"),
                Field("bank", 2, 1, "ro", 0, "toggles at every switch"),
                Field("rejected", 3, 1, "ro", 0,
                      "the last SWAP written was refused: the words written since the last "
                      "STREAM_ADDR write are not LENGTH words from BASE with CRC-32 = CRC; the old "
                      "stream keeps playing (cleared by a SWAP that is taken)")),
                     "channel control", ch),
            Register("LENGTH", base + 1, (Field("length", 0, c.length_width, "rw",
                                                min(max(ini.length, c.min_stream_length), c.pool_words),
                                                f"stream length in words for the next switch "
                                                f"({c.min_stream_length}..pool words)",
                                                clamp=(c.min_stream_length, c.pool_words)),),
                     "latched into the stream at the switch", ch),
            Register("PHASE_INC", base + 2, (Field("inc", 0, PHASE_FRAC_BITS, "rw",
                                                   min(ini.phase_increment & ((1 << PHASE_FRAC_BITS) - 1), c.max_phase_increment),
                                                   "stream words per sample * 2**32 for the next switch "
                                                   f"(0..{c.max_phase_increment}); output n plays the "
                                                   "phase held during step n",
                                                   clamp=(0, c.max_phase_increment)),),
                     "latched into the stream at the switch", ch),
            Register("GAIN", base + 3, (Field("gain", 0, GAIN_WIDTH, "rw", ini.gain,
                                              "gain, unsigned, 16 fractional bits; written before "
                                              "input k, from output k"),),
                     "written before input k: from output k (docs/fixed_point.md, Alignment)", ch),
            Register("DELAY", base + 4, (Field("delay", 0, _bits(maxd), "rw", min(ini.delay, maxd),
                                               f"tap of this channel in the window, samples (0..{maxd}), "
                                               "takes effect on APPLY", clamp=(0, maxd)),
                                         Field("applied", APPLIED_LSB, _bits(maxd), "ro", min(ini.delay, maxd),
                                               "the tap in effect (the last APPLY's)")),
                     "tap: delay beyond COMMON_DELAY", ch),
            Register("BASE", base + 5, (Field("base", 0, c.pool_address_width, "rw",
                                              ini.base & ((1 << c.pool_address_width) - 1),
                                              "pool address of word 0 of the stream for the next "
                                              "switch"),),
                     "latched into the stream at the switch", ch),
            Register("CRC", base + 6, (Field("crc", 0, 32, "w", 0,
                                             "CRC-32 (zlib) of the stream for the next switch: a SWAP "
                                             "is taken only if it equals STREAM_CRC and BASE and LENGTH "
                                             "are STREAM_ADDR's start and STREAM_COUNT, all three "
                                             "written since power-up; reads 0"),),
                     "checked at the switch", ch),
            Register("PLAYED", base + 7, (Field("crc", 0, 32, "ro", stream_crc32(ini.words) if ini.words else 0,
                                                "CRC-32 of the stream of the last SWAP taken: the stream "
                                                "the channel plays once CTRL.swap reads 0 (at power-up, "
                                                "its initial stream's)"),),
                     "what the channel plays: a load is done when it reads the CRC sent", ch),
        ]
        if c.scan:
            regs.append(Register("AZIMUTH", base + 8, (
                Field("azimuth", 0, AZIMUTH_BITS, "rw", ini.azimuth & (AZIMUTH_CODES - 1),
                      "the turbine's azimuth, 2**16 a revolution clockwise from north; written before "
                      "input k, from output k"),),
                "the antenna's two-way pattern at (beam - AZIMUTH) scales GAIN", ch))
        if c.start_frac:
            regs.append(Register("START", base + 9, (
                Field("frac", 0, PHASE_FRAC_BITS, "rw", 0,
                      "the stream of the next switch starts this fraction of its word 0 on, "
                      "2**-32 words (0: at the word)"),),
                "latched into the stream at the switch (docs/beam_following.md)", ch))
    return RegisterMap(c, regs)


def _follow_registers(c) -> list:
    """The registers of channels that follow the beam (docs/beam_following.md;
    the rule: ``rast.model.contract.follow``)."""
    rows_bits = c.follow_rows.bit_length()
    word_bits = (4 * c.follow_rows - 1).bit_length()
    return [
        Register("FOLLOW_CTRL", 0x1A, (
            Field("on", 0, 1, "rw", 0, "the channels follow the beam (load the table and the window first)"),
            Field("rows", 4, rows_bits, "rw", 0, f"rows in the turbine table (0..{c.follow_rows}), sorted by "
                  "azimuth", clamp=(0, c.follow_rows)),
            Field("capacity", 17, 13, "ro", c.follow_rows, "the table's most rows"),
            Field("start", 31, 1, "wo", 0, "write 1: the scene's step counter restarts at 0 with the step "
                  "this write lands before, and the channels are handed out afresh from the beam")),
            "channels that follow the beam: written before input k, from output k"),
        Register("FOLLOW_WINDOW", 0x1B, (
            Field("entry_off", 0, AZIMUTH_BITS, "rw", 0, "lo - guard (mod 2**16): a row enters at its "
                  "azimuth plus this"),
            Field("exit_off", 16, AZIMUTH_BITS, "rw", 0, "hi + 1 (mod 2**16): a row leaves at its azimuth "
                  "plus this")),
            "the window's codes (rast.model.contract.follow)"),
        Register("FOLLOW_SPAN", 0x1C, (
            Field("width", 0, AZIMUTH_BITS, "rw", 0, "W = hi + 1 - lo + guard: the codes a row holds a channel"),
            Field("guard", 16, AZIMUTH_BITS, "rw", 0, "codes a row takes its channel before the window")),
            "the window's codes (rast.model.contract.follow)"),
        Register("TABLE_ADDR", 0x1D, (
            Field("addr", 0, word_bits, "rw", 0, "turbine table word (4 a row); +1 after each TABLE_DATA"),),
            "the turbine table's write path: address"),
        Register("TABLE_DATA", 0x1E, (
            Field("word", 0, 32, "wo", 0, "a word of a row (rast.model.contract.follow.FOLLOW_ROW_FIELDS), "
                  "written at TABLE_ADDR"),),
            "the turbine table's write path: data"),
        Register("TABLE_CRC", 0x1F, (
            Field("crc", 0, 32, "ro", 0, "CRC-32 (zlib) of the TABLE_DATA words written since the last "
                  "TABLE_ADDR write"),),
            "the turbine table's write path: what the host checks before following"),
    ]


def _scan_registers() -> list:
    """The antenna scan's registers (docs/antenna_scan.md; the rule:
    ``rast.model.contract.scan``)."""
    return [
        Register("SCAN_CTRL", 0x10, (
            Field("mode", 0, 2, "rw", 0, "0 stare (every channel at its GAIN), 1 free running, "
                  "2 following the radar's ACP/ARP", clamp=(0, 2)),
            Field("anticlockwise", 2, 1, "rw", 0, "free running: the beam turns anticlockwise"),
            Field("auto", 3, 1, "rw", 0, "acp: learn the ACPs a revolution between two ARPs "
                  f"(at least {ACP_MIN_LEARN}, none missed)"),
            Field("acp_log2", 8, 5, "rw", 16, "acp without auto: 2**acp_log2 ACPs a revolution "
                  "(12: 4096, 14: 16384, 16: 65536)", clamp=(8, 16)),
            Field("restart", 31, 1, "wo", 0, "write 1: the beam restarts from the step this write "
                  "lands before (free: at SCAN_START; acp: count, code and what was learned cleared)")),
            "the beam: written before input k, from output k"),
        Register("SCAN_PERIOD", 0x11, (
            Field("samples", 0, 32, "rw", AZIMUTH_CODES, "free running: RTS samples a revolution, "
                  "round(sample rate * 60 / abs(rpm))", clamp=(AZIMUTH_CODES, (1 << 32) - 1)),),
            "the free-running beam's revolution"),
        Register("SCAN_START", 0x12, (
            Field("azimuth", 0, AZIMUTH_BITS, "rw", 0, "the beam's code a free restart loads"),),
            "the free-running beam's start"),
        Register("PATTERN", 0x13, (
            Field("shift", 0, 3, "rw", 0, f"the table's step is 2**shift azimuth codes (0..{MAX_PATTERN_SHIFT})",
                  clamp=(0, MAX_PATTERN_SHIFT)),
            Field("floor", 16, PATTERN_WIDTH, "rw", 0, "the pattern's word beyond the table's span")),
            "the two-way pattern: load it while SCAN_CTRL.mode is stare"),
        Register("PATTERN_ADDR", 0x14, (
            Field("addr", 0, PATTERN_INDEX_BITS, "rw", 0,
                  "table entry; +1 (mod the table) after each PATTERN_DATA"),),
            "the pattern table's write path: address"),
        Register("PATTERN_DATA", 0x15, (
            Field("word", 0, PATTERN_WIDTH, "wo", 0, "two-way amplitude, 2**15 = 0 dB, written at "
                  "PATTERN_ADDR into every pipeline's table"),),
            "the pattern table's write path: data"),
        Register("PATTERN_CRC", 0x16, (
            Field("crc", 0, 32, "ro", 0, "CRC-32 (zlib) of the PATTERN_DATA words written since the "
                  "last PATTERN_ADDR write, each as a 32-bit word (the 16-bit word, zero above)"),),
            "the pattern table's write path: what the host checks before the scan plays"),
        Register("SCAN_STATUS", 0x17, (
            Field("beam", 0, AZIMUTH_BITS, "ro", 0, "the beam's azimuth code now"),
            Field("learned", 16, 1, "ro", 0, "acp with auto: a revolution's count has been learned")),
            "the beam"),
        Register("ACP_PER_REV", 0x18, (
            Field("count", 0, 17, "ro", 1 << 16, "ACPs a revolution in use (acp mode)"),),
            "the beam: what the radar's revolution was learned as"),
    ]

