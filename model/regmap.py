"""The replay block's register map, described once.

The Amaranth register file (``rast.hdl.registers``), the bit-exact model
(``rast.model.datapath``), the host helpers below and ``docs/registers.md``
are all generated from :func:`register_map`. Plain Python, no Amaranth.

Bus: word addresses, 32-bit data, one access per clock, read data registered
(available the cycle after the read strobe).

Access kinds of a field:

``rw``  storage, reads back what was written (after clamping, see ``clamp``)
``ro``  read-only, driven by the hardware
``wo``  write strobe (command); reads as 0 unless a read meaning is given
``rc``  sticky status, cleared by a read of its register
"""

from dataclasses import dataclass, field
from pathlib import Path

from .fixedpoint import (ReplayContract, STREAM_WIDTH, GAIN_WIDTH, PHASE_FRAC_BITS, INTERPOLATIONS,
                         BOARD_INPUT_LATENCY, BOARD_OUTPUT_LATENCY, TARGETS, path_latency)

__all__ = ["Field", "Register", "RegisterMap", "register_map", "ChannelInit",
           "ID_VALUE", "CHANNEL_BASE", "CHANNEL_STRIDE", "CTRL_ENABLE", "CTRL_SWAP",
           "CTRL_BANK", "manifest_to_register_writes", "manifest_channel_inits",
           "read_hex_words", "markdown", "registers_doc"]

ID_VALUE = 0x52415354          # "RAST"
CHANNEL_BASE = 0x10
CHANNEL_STRIDE = 8
CTRL_ENABLE = 1 << 0
CTRL_SWAP = 1 << 1
CTRL_BANK = 1 << 2


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


@dataclass(frozen=True)
class ChannelInit:
    """Power-up contents of one channel: bank 0 words and register resets."""
    words: tuple = ()
    phase_increment: int = 0
    gain: int = 0
    delay: int = 0
    enable: bool = False

    @property
    def length(self) -> int:
        return max(1, len(self.words))


@dataclass
class RegisterMap:
    contract: ReplayContract
    registers: list = field(default_factory=list)

    def __post_init__(self):
        self._by_key = {(r.name, r.channel): r for r in self.registers}

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

    def by_addr(self, addr) -> Register | None:
        for r in self.registers:
            if r.addr == addr:
                return r
        return None


def _bits(n: int) -> int:
    return max(1, int(n).bit_length())


def register_map(contract: ReplayContract, inits=None) -> RegisterMap:
    """The register map of a replay block built with ``contract``.

    ``inits`` (a list of :class:`ChannelInit`, one per channel or fewer) sets
    the reset values of the per-channel registers.
    """
    c = contract
    inits = list(inits or [])
    inits += [ChannelInit()] * (c.channels - len(inits))
    interp_code = INTERPOLATIONS.index(c.interpolation)
    config = c.channels | (interp_code << 8) | (int(c.cmult_form == "3mult") << 10)
    regs = [
        Register("ID", 0x00, (Field("id", 0, 32, "ro", ID_VALUE, "constant 0x52415354 ('RAST')"),),
                 "identification"),
        Register("CONFIG", 0x01, (Field("channels", 0, 8, "ro", c.channels, "channel count N"),
                                  Field("interpolation", 8, 2, "ro", interp_code,
                                        "stream interpolation: 0 hold, 1 linear, 2 FIR"),
                                  Field("cmult3", 10, 1, "ro", int(c.cmult_form == "3mult"),
                                        "1: 3-multiplier complex product")),
                 f"elaboration parameters (reads {config:#x} here)"),
        Register("LATENCY", 0x02, (Field("latency", 0, 16, "ro", c.latency,
                                         "fixed latency L in samples"),),
                 "echo of channel l appears L + sum(DELAY[0..l]) samples after its input"),
        Register("STATUS", 0x03, (Field("overflow", 0, 1, "rc", 0,
                                        "an output sample saturated since the last read"),),
                 "sticky status, cleared by reading"),
        Register("APPLY", 0x04, (Field("delays", 0, 1, "wo", 0,
                                       "write 1: all channels' DELAY take effect in the same sample"),),
                 "commands"),
        Register("STREAM_SEL", 0x05, (Field("channel", 0, _bits(c.channels - 1), "rw", 0,
                                            "channel whose stream RAM STREAM_DATA writes"),),
                 "stream write path: channel"),
        Register("STREAM_ADDR", 0x06, (Field("addr", 0, _bits(c.stream_depth - 1), "rw", 0,
                                             "word address in the inactive bank; +1 after each STREAM_DATA"),),
                 "stream write path: address"),
        Register("STREAM_DATA", 0x07, (Field("data", 0, 2 * STREAM_WIDTH, "wo", 0,
                                             "stream word, I low, Q high; written to the inactive bank; "
                                             "ignored while that channel's swap is pending"),),
                 "stream write path: data"),
        Register("STREAM_DEPTH", 0x08, (Field("depth", 0, 32, "ro", c.stream_depth, "words per bank"),),
                 "capability"),
        Register("MAX_DELAY", 0x09, (Field("max", 0, 32, "ro", c.max_delay, "largest DELAY of channel 0"),),
                 "capability"),
        Register("MAX_INCREMENT", 0x0A, (Field("max", 0, 32, "ro", c.max_increment,
                                               "largest DELAY of channels 1..N-1"),),
                 "capability"),
        Register("SAMPLE_RATE", 0x0B, (Field("hz", 0, 32, "ro", c.sample_rate_hz,
                                             "RTS sample rate the block was built for, Hz "
                                             "(0: not stated)"),),
                 "capability: a manifest for another rate plays every Doppler and range wrong"),
    ]
    for ch in range(c.channels):
        base = CHANNEL_BASE + CHANNEL_STRIDE * ch
        ini = inits[ch]
        maxd = c.max_segment_delay(ch)
        regs += [
            Register("CTRL", base + 0, (
                Field("enable", 0, 1, "rw", int(ini.enable), "channel contributes to the sum; "
                      "written before input k, from output k + 3(N - l)"),
                Field("swap", 1, 1, "wo", 0,
                      "write 1: switch to the other bank at the next period boundary (at once if "
                      "the write leaves the channel disabled); reads 1 while pending"),
                Field("bank", 2, 1, "ro", 0, "active bank")), "channel control", ch),
            Register("LENGTH", base + 1, (Field("length", 0, c.length_width, "rw",
                                                min(max(ini.length, c.min_stream_length), c.stream_depth),
                                                f"stream length in words for the next bank "
                                                f"({c.min_stream_length}..depth)",
                                                clamp=(c.min_stream_length, c.stream_depth)),),
                     "latched into the stream at the bank switch", ch),
            Register("PHASE_INC", base + 2, (Field("inc", 0, PHASE_FRAC_BITS, "rw",
                                                   min(ini.phase_increment & ((1 << PHASE_FRAC_BITS) - 1), c.max_phase_increment),
                                                   "stream words per sample * 2**32 for the next bank "
                                                   f"(0..{c.max_phase_increment}); output n plays the "
                                                   "phase of input step n - L + 3l + 3 - SL",
                                                   clamp=(0, c.max_phase_increment)),),
                     "latched into the stream at the bank switch", ch),
            Register("GAIN", base + 3, (Field("gain", 0, GAIN_WIDTH, "rw", ini.gain,
                                              "gain, unsigned, 16 fractional bits; written before "
                                              "input k, from output k + 3(N - l)"),),
                     "written before input k: from output k + 3(N - l) (docs/fixed_point.md, Alignment)", ch),
            Register("DELAY", base + 4, (Field("delay", 0, _bits(maxd), "rw", min(ini.delay, maxd),
                                               "delay of this segment in samples (0..max), "
                                               "takes effect on APPLY", clamp=(0, maxd)),),
                     "common delay (channel 0) or increment over the previous channel", ch),
        ]
    return RegisterMap(c, regs)


def markdown(rmap: RegisterMap) -> str:
    """The register map as a Markdown table (globals and channel 0)."""
    lines = ["| addr | register | field | bits | access | reset | meaning |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rmap.registers:
        if r.channel not in (None, 0):
            continue
        name = r.name if r.channel is None else f"CH[l].{r.name}"
        addr = f"{r.addr:#04x}" if r.channel is None else f"{r.addr:#04x} + {CHANNEL_STRIDE}*l"
        for f in r.fields:
            bits = f"{f.lsb + f.width - 1}:{f.lsb}" if f.width > 1 else f"{f.lsb}"
            lines.append(f"| {addr} | {name} | {f.name} | {bits} | {f.access} | "
                         f"{f.reset:#x} | {f.doc} |")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# Host side: from a `rast stream` manifest to register writes.
# ---------------------------------------------------------------------------

def read_hex_words(path) -> list:
    return [int(line, 16) for line in Path(path).read_text().split()]


def _check_build(manifest, contract):
    """A manifest states the sample rate and interpolation its streams were
    made for: refuse it for a block built otherwise (naming both numbers)."""
    rate = manifest.get("sample_rate_hz")
    if rate is not None and contract.sample_rate_hz and round(float(rate)) != contract.sample_rate_hz:
        ratio = contract.sample_rate_hz / float(rate)
        raise ValueError(f"Manifest was made for a sample rate of {float(rate) / 1e6:g} MHz "
                         f"(sample_rate_hz {round(float(rate))}) but the replay block runs at "
                         f"{contract.sample_rate_hz / 1e6:g} MHz ({contract.sample_rate_hz}): every "
                         f"Doppler would play {ratio:.3g}x too high and every range {ratio:.3g}x too "
                         f"short; make the streams for this build (rast stream --build report.json)")
    interp = manifest.get("interpolation")
    if interp is not None and interp != contract.interpolation:
        raise ValueError(f"Manifest's streams were made for {interp} interpolation but the replay block "
                         f"interpolates with {contract.interpolation}")


#: The manifest's ``calibration`` keys of the converters (RTS samples; absent: 0).
CALIBRATION_KEYS = {"adc_latency_samples": "ADC", "dac_latency_samples": "DAC"}


def _calibration(manifest) -> dict:
    """The converters' latencies from a manifest's ``calibration`` (0 when a
    manifest has none: one written before the keys existed)."""
    cal = manifest.get("calibration")
    if cal is None:
        return {k: 0 for k in CALIBRATION_KEYS}
    if not isinstance(cal, dict):
        raise ValueError(f"Manifest's 'calibration' must be an object, not {cal!r}")
    out = {}
    for key in CALIBRATION_KEYS:
        v = cal.get(key, 0)
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise ValueError(f"Manifest's calibration {key!r} must be a non-negative integer "
                             f"(RTS samples), not {v!r}")
        out[key] = v
    return out


def _fixed_latency(manifest, contract, target):
    """``(total, text)``: the samples the path into which the manifest is
    loaded adds at zero programmed delay, and their parts in words."""
    if target not in TARGETS:
        raise ValueError(f"Target must be one of {', '.join(TARGETS)}, not {target!r}")
    L = contract.latency
    cal = _calibration(manifest)
    if target == "block":
        return L, f"the replay block's fixed latency of {L} samples"
    adc, dac = cal["adc_latency_samples"], cal["dac_latency_samples"]
    total = path_latency(L, "board", adc, dac)
    return total, (f"the board's fixed latency of {total} samples (replay block L {L} + board input "
                   f"stage {BOARD_INPUT_LATENCY} + board output stage {BOARD_OUTPUT_LATENCY} + ADC "
                   f"{adc} (adc_latency) + DAC {dac} (dac_latency))")


def _channel_values(manifest, contract, target="block"):
    _check_build(manifest, contract)
    chans = manifest["registers"]["channels"]
    if len(chans) > contract.channels:
        raise ValueError(f"Manifest has {len(chans)} windmills but the replay block has "
                         f"{contract.channels} channels")
    fixed, parts = _fixed_latency(manifest, contract, target)
    out = []
    for i, ch in enumerate(chans):
        delay = int(ch["delay_increment"])
        if i == 0:
            if delay < fixed:
                raise ValueError(f"Common delay of {delay} samples (windmill {ch['windmill']!r}) is "
                                 f"shorter than {parts}")
            delay -= fixed
        maxd = contract.max_segment_delay(i)
        if not 0 <= delay <= maxd:
            what = "Common delay" if i == 0 else "Delay increment"
            raise ValueError(f"{what} of channel {i} ({ch['windmill']!r}) must be in [0, {maxd}] "
                             f"samples after subtracting the latency, not {delay}")
        length = int(ch["length"])
        if not contract.min_stream_length <= length <= contract.stream_depth:
            raise ValueError(f"Stream length of channel {i} ({ch['windmill']!r}) must be in "
                             f"[{contract.min_stream_length}, {contract.stream_depth}] words, not {length}")
        inc = int(ch["phase_increment"])
        if not 0 <= inc <= contract.max_phase_increment:
            raise ValueError(f"Phase increment of channel {i} ({ch['windmill']!r}) must be in "
                             f"[0, {contract.max_phase_increment}] ({contract.interpolation} "
                             f"interpolation), not {inc}")
        gain = int(ch["gain"])
        if not 0 <= gain < (1 << GAIN_WIDTH):
            raise ValueError(f"Gain word of channel {i} ({ch['windmill']!r}) must be in "
                             f"[0, {(1 << GAIN_WIDTH) - 1}], not {gain}")
        out.append(dict(name=ch["windmill"], enable=int(ch.get("enable", 1)), length=length,
                        inc=inc, gain=gain, delay=delay))
    return out


def _load_streams(manifest, stream_dir, streams, values):
    if streams is not None:
        return [list(map(int, s)) for s in streams]
    if stream_dir is None:
        return None
    by_name = {w["name"]: w for w in manifest["windmills"]}
    words = []
    for v in values:
        w = read_hex_words(Path(stream_dir) / by_name[v["name"]]["hex_file"])
        if len(w) != v["length"]:
            raise ValueError(f"{by_name[v['name']]['hex_file']} has {len(w)} words, the manifest says "
                             f"{v['length']}")
        words.append(w)
    return words


def manifest_to_register_writes(manifest: dict, contract: ReplayContract | None = None, *,
                                stream_dir=None, streams=None, target: str = "block") -> list:
    """Register writes ``[(addr, value), ...]`` that load a manifest into a running block.

    The windmill of list position ``l`` goes to channel ``l``; the rest are
    disabled. Channel 0's DELAY is the manifest's common delay minus the fixed
    latency of the path the block sits in, so that the echo lands at
    ``delay_samples``; channels 1.. get their increments. ``target`` says
    which path:

    * ``"board"``: the board top (``rast.gateware.top.BoardTop``), loaded by
      ``rast load`` or baked in for power-up. ``DELAY[0] = delay_samples - L
      - BOARD_INPUT_LATENCY - BOARD_OUTPUT_LATENCY - adc - dac``, with the
      converters' latencies from the manifest's ``calibration``
      (``adc_latency_samples``, ``dac_latency_samples``; 0 when a manifest has
      none): the echo leaves the DAC ``delay_samples`` after the pulse reached
      the ADC.
    * ``"block"`` (the default, the behaviour before ``target`` existed): the
      bare replay block, as the cosimulations drive it (``rast.sim.e2e``,
      ``rast.sim.scenario``): ``DELAY[0] = delay_samples - L``, the echo at
      ``delay_samples`` counted at the block's own ports; the board's stages
      and the converters are not in that path and are not subtracted.

    A windmill closer than the fixed latency is refused, naming its parts.
    With ``stream_dir`` (the manifest's
    folder, to read the ``.hex`` files) or ``streams`` (word lists) the
    streams are written too; each channel is disabled, its words written into
    the inactive bank, the bank switched, then re-enabled. Without streams only
    gains and delays are written (LENGTH/PHASE_INC too, taking effect at the
    next bank switch).
    """
    contract = contract or ReplayContract(channels=len(manifest["registers"]["channels"]))
    rmap = register_map(contract)
    values = _channel_values(manifest, contract, target)
    words = _load_streams(manifest, stream_dir, streams, values)
    w = []
    a = rmap.addr
    for ch, v in enumerate(values):
        if words is not None:
            w.append((a("CTRL", ch), 0))
            w.append((a("STREAM_SEL"), ch))
            w.append((a("STREAM_ADDR"), 0))
            w += [(a("STREAM_DATA"), int(x) & 0xFFFFFFFF) for x in words[ch]]
        w.append((a("LENGTH", ch), v["length"]))
        w.append((a("PHASE_INC", ch), v["inc"]))
        w.append((a("GAIN", ch), v["gain"]))
        w.append((a("DELAY", ch), v["delay"]))
        if words is not None:
            w.append((a("CTRL", ch), CTRL_SWAP))           # disabled: switches at once
        w.append((a("CTRL", ch), CTRL_ENABLE if v["enable"] else 0))
    for ch in range(len(values), contract.channels):
        w.append((a("CTRL", ch), 0))
        w.append((a("GAIN", ch), 0))
        w.append((a("DELAY", ch), 0))
    w.append((a("APPLY"), 1))
    return w


def manifest_channel_inits(manifest: dict, contract: ReplayContract, stream_dir=None,
                           streams=None, *, target: str = "block") -> list:
    """Power-up contents (:class:`ChannelInit` per channel) from a manifest, for
    a bitstream that replays it without a host; ``target`` as for
    :func:`manifest_to_register_writes` (``"board"`` for a board top)."""
    values = _channel_values(manifest, contract, target)
    words = _load_streams(manifest, stream_dir, streams, values)
    if words is None:
        raise ValueError("Channel initialisation needs the streams: give stream_dir or streams")
    return [ChannelInit(tuple(words[i]), v["inc"], v["gain"], v["delay"], bool(v["enable"]))
            for i, v in enumerate(values)]


def registers_doc(contract: ReplayContract | None = None) -> str:
    """The text of docs/registers.md (regenerate: ``python -m rast.model.regmap``)."""
    c = contract or ReplayContract()
    return f"""# Replay block registers

Generated by `python -m rast.model.regmap > docs/registers.md` from
`rast/model/regmap.py`, the description the gateware register file and the
host helpers are built from. Widths shown for the default build
(N={c.channels}, stream depth {c.stream_depth}, max delay {c.max_delay},
max increment {c.max_increment}); widths of LENGTH, DELAY and STREAM_SEL/ADDR
follow the elaboration parameters.

Bus (`rast.hdl.registers.BusSignature`): word addresses, 32-bit data, one
access per cycle; `w_stb` writes `w_data` to `addr`; `r_stb` reads `addr`,
`r_data` is valid the next cycle. Unused addresses read 0. Written values are
masked to the field width, then clamped into the field's range where one is
given (LENGTH 1..depth, DELAY 0..max).

Timing: a write takes effect from the next accepted input sample on (a write
in the same clock cycle as an input transfer counts as after it). Status bits
(CTRL.swap/bank, STATUS.overflow) read the state after this cycle's sample.

{markdown(register_map(c))}
Channel l (0..N-1) has its block at `{CHANNEL_BASE:#x} + {CHANNEL_STRIDE}*l`.

## Loading a stream (no torn period)

Each channel has two RAM banks; the replay reads the active one, STREAM_DATA
writes go to the other (ignored while a switch is pending). A switch latches
LENGTH and PHASE_INC and restarts the stream at word 0.

While running:
1. `STREAM_SEL = l`, `STREAM_ADDR = 0`, then `length` writes of STREAM_DATA;
2. `LENGTH[l]`, `PHASE_INC[l]`;
3. `CTRL[l] = ENABLE|SWAP` - the switch happens in the sample at which the
   old stream wraps (period boundary); poll CTRL[l] bit 1 until 0 before the next load.

Stopped channel: `CTRL[l] = 0`, steps 1-2, then `CTRL[l] = SWAP` (switches at
once because the channel is disabled), then `CTRL[l] = ENABLE`.
`manifest_to_register_writes` produces the second sequence.

Delays: write DELAY[l] for any channels, then `APPLY = 1`: all take effect in
the same sample.
"""


if __name__ == "__main__":
    print(registers_doc(), end="")
