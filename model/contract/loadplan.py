"""The host side of loading: from a `rast stream` manifest to the register
writes that load it (``rast load``, the cosimulations) or the power-up state
that bakes it in (``rast verilog --manifest``), with the checks that refuse a
manifest made for another build."""

from dataclasses import dataclass
from pathlib import Path

from rast.model.contract.fixedpoint import (ReplayContract, GAIN_WIDTH, TARGETS, path_latency,
                                            board_input_latency, board_output_latency, rate_mismatch)
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.regmap import (register_map, stream_crc32, RegisterMap, CTRL_ENABLE, CTRL_SWAP,
                                        SCAN_RESTART)
from rast.model.contract.scan import PATTERN_ENTRIES, PATTERN_ONE, AZIMUTH_CODES

__all__ = ["read_hex_words", "CALIBRATION_KEYS", "pool_layout", "channel_regions", "free_region", "stream_writes",
           "NoRoomBeside", "manifest_to_register_writes", "manifest_channel_inits", "FollowLoad", "follow_load",
           "follow_register_writes"]


def read_hex_words(path) -> list:
    return [int(line, 16) for line in Path(path).read_text().split()]


def _check_build(manifest, contract):
    """A manifest states the sample rate and interpolation its streams were
    made for: refuse it for a block built otherwise (naming both numbers)."""
    rate = manifest.get("sample_rate_hz")
    if rate is not None and contract.sample_rate_hz and round(float(rate)) != contract.sample_rate_hz:
        raise ValueError(f"Manifest was made for a sample rate of {float(rate) / 1e6:g} MHz "
                         f"(sample_rate_hz {round(float(rate))}) but the replay block runs at "
                         f"{contract.sample_rate_hz / 1e6:g} MHz ({contract.sample_rate_hz}): "
                         f"{rate_mismatch(float(rate), contract.sample_rate_hz)}; make the streams "
                         f"for this build (rast stream --build report.json)")
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
    total = path_latency(contract, "board", adc, dac)
    return total, (f"the board's fixed latency of {total} samples (replay block L {L} + ADC pins to "
                   f"the block {board_input_latency(contract.slots)} + the block's pipeline to the "
                   f"DAC pins {board_output_latency(contract)} + ADC {adc} (adc_latency) + DAC {dac} "
                   f"(dac_latency))")


def _channel_values(manifest, contract, target="block", rows=False):
    """``(common_delay, [per-channel values])``: COMMON_DELAY reaches the
    nearest windmill (at most ``max_delay``), each channel's tap the rest of
    its delay beyond the fixed latency. ``rows``: the windmills are rows of
    a turbine table (channels that follow the beam), not channels."""
    _check_build(manifest, contract)
    chans = manifest["registers"]["channels"]
    if rows and len(chans) > contract.follow_rows:
        raise ValueError(f"Manifest has {len(chans)} windmills but the replay block's turbine table "
                         f"holds {contract.follow_rows} rows")
    if not rows and len(chans) > contract.channels:
        raise ValueError(f"Manifest has {len(chans)} windmills but the replay block has "
                         f"{contract.channels} channels")
    fixed, parts = _fixed_latency(manifest, contract, target)
    delays = [int(ch["delay_samples"]) for ch in chans]
    near = min(range(len(chans)), key=lambda i: delays[i])
    if delays[near] < fixed:
        raise ValueError(f"Delay of {delays[near]} samples (windmill {chans[near]['windmill']!r}) is "
                         f"shorter than {parts}")
    common = min(delays[near] - fixed, contract.max_delay)
    out = []
    for i, ch in enumerate(chans):
        delay = delays[i] - fixed - common
        if delay > contract.max_tap:
            raise ValueError(
                f"Windmill {ch['windmill']!r} (channel {i}) lies {delay} samples beyond the common delay "
                f"of {common} samples (after subtracting the latency), but the delay window reaches "
                f"{contract.max_tap}: the farm is {max(delays) - delays[near]} samples deep"
                + ("" if common < contract.max_delay else
                   f" and its nearest windmill beyond the longest common delay ({contract.max_delay})"))
        length = int(ch["length"])
        if not contract.min_stream_length <= length <= contract.pool_words:
            raise ValueError(f"Stream length of channel {i} ({ch['windmill']!r}) must be in "
                             f"[{contract.min_stream_length}, {contract.pool_words}] words, not {length}")
        inc = int(ch["phase_increment"])
        if not 0 <= inc <= contract.max_phase_increment:
            raise ValueError(f"Phase increment of channel {i} ({ch['windmill']!r}) must be in "
                             f"[0, {contract.max_phase_increment}] ({contract.interpolation} "
                             f"interpolation), not {inc}")
        gain = int(ch["gain"])
        if not 0 <= gain < (1 << GAIN_WIDTH):
            raise ValueError(f"Gain word of channel {i} ({ch['windmill']!r}) must be in "
                             f"[0, {(1 << GAIN_WIDTH) - 1}], not {gain}")
        azimuth = int(ch.get("azimuth", 0))
        if not 0 <= azimuth < AZIMUTH_CODES:
            raise ValueError(f"Azimuth code of channel {i} ({ch['windmill']!r}) must be in "
                             f"[0, {AZIMUTH_CODES - 1}], not {azimuth}")
        out.append(dict(name=ch["windmill"], enable=int(ch.get("enable", 1)), length=length,
                        inc=inc, gain=gain, delay=delay, azimuth=azimuth))
    return common, out


def _check_scan(manifest, contract):
    """The manifest's ``scan`` (None when it stares), checked against the block."""
    scan = manifest.get("scan")
    if scan is None:
        return None
    if not contract.scan:
        raise ValueError(f"The manifest turns the antenna (scan mode {scan.get('scan_mode')!r}) but the "
                         "replay block has no antenna scan: build it with --scan")
    table = scan["pattern"]
    words = table["words"]
    if len(words) != PATTERN_ENTRIES or not all(0 <= int(w) <= PATTERN_ONE for w in words):
        raise ValueError(f"The manifest's pattern must be {PATTERN_ENTRIES} words in [0, {PATTERN_ONE}]")
    return scan


def scan_writes(rmap: RegisterMap, scan) -> tuple[list, list]:
    """The writes that load the antenna scan ``scan`` (a manifest's ``scan``,
    ``rast.model.contract.scan.scan_settings``), in two parts: the table
    (SCAN_CTRL = 0 first: no channel sees it while it changes; PATTERN,
    PATTERN_ADDR, the words), after which the host checks PATTERN_CRC
    against the CRC-32 of the words, and the scan's start (SCAN_PERIOD,
    SCAN_START, SCAN_CTRL with its mode and the restart). ``None``: the
    block stares (SCAN_CTRL = 0)."""
    a = rmap.addr
    if scan is None:
        return [(a("SCAN_CTRL"), 0)], []
    table = scan["pattern"]
    load = [(a("SCAN_CTRL"), 0), (a("PATTERN"), int(table["shift"]) | int(table["floor"]) << 16),
            (a("PATTERN_ADDR"), 0)] + [(a("PATTERN_DATA"), int(w)) for w in table["words"]]
    ctrl = (int(scan["mode"]) | int(scan["anticlockwise"]) << 2 | int(scan["auto"]) << 3
            | int(scan["acp_log2"]) << 8 | SCAN_RESTART)
    start = [(a("SCAN_PERIOD"), int(scan["period_samples"])), (a("SCAN_START"), int(scan["start_code"])),
             (a("SCAN_CTRL"), ctrl)]
    return load, start


def pattern_crc(scan) -> int:
    """What PATTERN_CRC reads after :func:`scan_writes`' table."""
    return stream_crc32([int(w) for w in scan["pattern"]["words"]])


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


def pool_layout(lengths, pool_words: int, regions=None) -> list:
    """Pool addresses of streams of ``lengths`` words placed one after the
    other from address 0 (a full load); refuses streams that do not fit.
    ``regions`` (per stream ``None`` or ``(key, offset, words)``, see
    :func:`channel_regions`): the streams of one key share a region of
    ``words`` words placed where its first stream comes, each ``offset``
    words into it (streams shared between alike turbines,
    ``rast.model.physics.sharing``)."""
    bases, at, placed = [], 0, {}
    for k, n in enumerate(lengths):
        region = regions[k] if regions else None
        if region is None:
            bases.append(at)
            at += int(n)
            continue
        key, offset, words = region
        if key not in placed:
            placed[key] = at
            at += int(words)
        bases.append(placed[key] + int(offset))
    if at > pool_words:
        raise ValueError(f"Streams need {at} words together but the stream pool holds {pool_words}")
    return bases


def channel_regions(channels) -> list:
    """Per manifest channel entry, the shared region its stream lies in
    (``pool_region``: ``(stream, offset, words)``), or None."""
    return [(c["pool_region"]["stream"], int(c["pool_region"]["offset"]), int(c["pool_region"]["words"]))
            if "pool_region" in c else None for c in channels]


def free_region(in_use, length: int, pool_words: int) -> int:
    """First pool address with ``length`` free words, given the regions
    ``in_use`` (``(base, length)`` pairs, e.g. every channel's active stream
    and any pending one); for a reload while running."""
    at = 0
    for base, n in sorted((int(b), int(n)) for b, n in in_use):
        if base - at >= length:
            return at
        at = max(at, base + n)
    if pool_words - at >= length:
        return at
    raise ValueError(f"No {length} free words in the stream pool of {pool_words} words "
                     f"(in use: {sorted(in_use)})")


class NoRoomBeside(ValueError):
    """The new streams do not fit in the pool beside the streams playing."""


def _live_layout(lengths, playing, pool_words: int, regions=None) -> list:
    """Pool addresses for streams of ``lengths`` (one per channel) that leave
    every stream in ``playing`` (per channel ``(base, length)`` or ``None``)
    untouched, as each channel plays its old stream until it switches; the
    new streams do not overlap each other either (a shared region, see
    :func:`pool_layout`, is placed once). Raises :class:`NoRoomBeside`."""
    in_use = [r for r in playing if r is not None]
    bases, placed = [], {}
    for ch, n in enumerate(lengths):
        key, offset, words = (regions[ch] if regions and regions[ch] else (None, 0, n))
        if key in placed:
            bases.append(placed[key] + offset)
            continue
        try:
            start = free_region(in_use, words, pool_words)
        except ValueError:
            old = sum(r[1] for r in playing if r is not None)
            raise NoRoomBeside(
                f"the new streams ({sum(lengths)} words) do not fit beside the {old} words playing "
                f"in the pool of {pool_words} words (no {words} free words for channel {ch})") from None
        in_use.append((start, words))
        if key is not None:
            placed[key] = start
        bases.append(start + offset)
    return bases


def stream_writes(rmap: RegisterMap, channel: int, base: int, words, increment: int) -> list:
    """Register writes ``[(addr, value), ...]`` that put a stream in the pool
    at ``base`` and name it for ``channel``'s next switch: STREAM_ADDR, every
    word (STREAM_DATA), BASE, LENGTH, PHASE_INC and CRC (its CRC-32). The
    switch (CTRL.swap) is the caller's and must come before the next
    STREAM_ADDR write: the block takes it only for the words written since
    the last one, all LENGTH of them from BASE, with that CRC-32."""
    a = rmap.addr
    words = [int(x) & 0xFFFFFFFF for x in words]
    return ([(a("STREAM_ADDR"), base)] + [(a("STREAM_DATA"), x) for x in words]
            + [(a("BASE", channel), base), (a("LENGTH", channel), len(words)),
               (a("PHASE_INC", channel), increment), (a("CRC", channel), stream_crc32(words))])


def manifest_to_register_writes(manifest: dict, contract: ReplayContract | None = None, *,
                                stream_dir=None, streams=None, target: str = "block",
                                playing=None, with_scan: bool = True) -> list:
    """Register writes ``[(addr, value), ...]`` that load a manifest into a running block.

    The windmill of list position ``l`` goes to channel ``l``; the rest are
    disabled. COMMON_DELAY is the nearest windmill's ``delay_samples`` minus
    the fixed latency of the path the block sits in (at most ``max_delay``),
    and each channel's DELAY (tap) the rest of its ``delay_samples``, so that
    every echo lands at its ``delay_samples``. ``target`` says which path:

    * ``"board"``: the board top (``rast.gateware.top.BoardTop``), loaded by
      ``rast load`` or baked in for power-up. ``COMMON_DELAY + DELAY[l] =
      delay_samples - board_latency - adc - dac`` (``board_latency``: L, the
      board's input stage and the block's pipeline to the DAC pins), with the
      converters' latencies from the manifest's ``calibration``
      (``adc_latency_samples``, ``dac_latency_samples``; 0 when a manifest has
      none): the echo leaves the DAC ``delay_samples`` after the pulse reached
      the ADC.
    * ``"block"`` (the default): the bare replay block, as the cosimulations
      drive it (``rast.sim.e2e``, ``rast.sim.scenario``): ``COMMON_DELAY +
      DELAY[l] = delay_samples - L``, the echo at ``delay_samples`` counted at the
      block's own ports; the board's stages and the converters are not in
      that path and are not subtracted.

    A windmill closer than the fixed latency is refused, naming its parts.
    With ``stream_dir`` (the manifest's folder, to read the ``.hex`` files) or
    ``streams`` (word lists) the streams are written too, one after the other
    from pool address 0 (:func:`pool_layout`): every channel is disabled
    first (a full load replaces every stream), then per channel its words,
    BASE/LENGTH/PHASE_INC/CRC (:func:`stream_writes`), the switch (at once:
    disabled; the block checks the stream's CRC-32 first) and the re-enable.
    Without streams only gains and delays are written (BASE/LENGTH/PHASE_INC
    are not touched).

    ``playing`` (per channel of the block, the ``(base, length)`` of the
    stream it plays, or ``None`` when it plays none: disabled, or its stream
    never wraps) makes the load live: no channel is disabled, the new streams
    go where no playing stream lies (:class:`NoRoomBeside` when they do not
    fit), and a playing channel switches at its stream's next period boundary
    (CTRL enable + swap: it plays its old stream until then, and goes on
    playing it if the block refuses the switch); the others switch at once.
    A channel's gain changes when written, its delay at APPLY (the end).

    A block built with the antenna scan gets each channel's AZIMUTH and,
    last, the scan (:func:`scan_writes`: the pattern, then the scan's start;
    SCAN_CTRL = 0 for a manifest that stares) unless ``with_scan`` is False
    (a loader that checks the pattern's CRC before the scan starts sends
    them itself). A manifest that turns the antenna is refused by a block
    without the scan.
    """
    contract = contract or ReplayContract(channels=len(manifest["registers"]["channels"]))
    rmap = register_map(contract)
    common, values = _channel_values(manifest, contract, target)
    scan = _check_scan(manifest, contract)
    words = _load_streams(manifest, stream_dir, streams, values)
    w = []
    a = rmap.addr
    live = words is not None and playing is not None
    regions = channel_regions(manifest["registers"]["channels"])
    if live:
        playing = list(playing) + [None] * (contract.channels - len(playing))
        bases = _live_layout([len(x) for x in words], playing, contract.pool_words, regions)
    elif words is not None:
        bases = pool_layout([len(x) for x in words], contract.pool_words, regions)
        w += [(a("CTRL", ch), 0) for ch in range(contract.channels)]
    for ch, v in enumerate(values):
        if words is not None:
            w += stream_writes(rmap, ch, bases[ch], words[ch], v["inc"])
        w.append((a("GAIN", ch), v["gain"]))
        w.append((a("DELAY", ch), v["delay"]))
        if contract.scan:
            w.append((a("AZIMUTH", ch), v["azimuth"]))
        enable = CTRL_ENABLE if v["enable"] else 0
        if live and playing[ch] is not None and enable:
            w.append((a("CTRL", ch), enable | CTRL_SWAP))  # at its period boundary
            continue
        if words is not None:
            if live:
                w.append((a("CTRL", ch), 0))               # (a live load leaves it on till now)
            w.append((a("CTRL", ch), CTRL_SWAP))           # disabled: switches at once
        w.append((a("CTRL", ch), enable))
    for ch in range(len(values), contract.channels):
        w.append((a("CTRL", ch), 0))
        w.append((a("GAIN", ch), 0))
        w.append((a("DELAY", ch), 0))
    w.append((a("COMMON_DELAY"), common))
    w.append((a("APPLY"), 1))
    if contract.scan and with_scan:
        load, start = scan_writes(rmap, scan)
        w += load + start
    return w


def manifest_channel_inits(manifest: dict, contract: ReplayContract, stream_dir=None,
                           streams=None, *, target: str = "block") -> tuple[list, int]:
    """Power-up contents from a manifest, for a bitstream that replays it
    without a host: ``(inits, common_delay)``, a :class:`ChannelInit` per
    channel and the COMMON_DELAY; ``target`` as for
    :func:`manifest_to_register_writes` (``"board"`` for a board top). The
    streams sit in the pool as :func:`pool_layout` places them."""
    common, values = _channel_values(manifest, contract, target)
    words = _load_streams(manifest, stream_dir, streams, values)
    if words is None:
        raise ValueError("Channel initialisation needs the streams: give stream_dir or streams")
    bases = pool_layout([len(x) for x in words], contract.pool_words,
                        channel_regions(manifest["registers"]["channels"]))
    return [ChannelInit(tuple(words[i]), v["inc"], v["gain"], v["delay"], bool(v["enable"]), bases[i],
                        v["azimuth"]) for i, v in enumerate(values)], common


@dataclass
class FollowLoad:
    """What loads a turning manifest into a block whose channels follow the
    beam (:func:`follow_load`): ``regions`` (pool base, words) of the rolled
    streams, each checked by the host against STREAM_CRC after its words;
    ``table`` the turbine table's words (TABLE_CRC is their CRC-32); the
    register writes ``stop`` (channels and following off), ``settings``
    (the zeroed pattern, the window, the delays, the channels on) and
    ``start`` (FOLLOW_CTRL with the start and the scan's start)."""
    regions: list
    table: list
    rows: list
    stop: list
    settings: list
    start: list
    guard: int

    @property
    def table_crc(self) -> int:
        return stream_crc32(self.table)


def follow_load(manifest: dict, contract: ReplayContract, *, stream_dir=None, streams=None,
                target: str = "board") -> FollowLoad:
    """A turning manifest for a block built with ``follow_rows``: each
    windmill a row of the turbine table (sorted by azimuth), each stream held
    rolled (its period and then all but one of its words again, so that the
    loader may start it at any word: BASE = the row's base + the phase's whole
    words), a region shared between alike windmills likewise (every member's
    start plus twice the period but one word), the pattern with the entries
    at or below ``assign_below_db`` at 0, and the guard timed on ``contract``
    for its channels (``rast.model.contract.follow``). Refused: a block
    without following, a manifest that stares or whose pattern's floor lies
    above ``assign_below_db``, more windmills than rows, a pool too small."""
    from types import SimpleNamespace
    from rast.model.contract.follow import FollowRow, follow_guard_codes, pack_rows
    if not contract.follow_rows:
        raise ValueError("the replay block's channels do not follow the beam: build it with --follow")
    scan = _check_scan(manifest, contract)
    follow = manifest.get("follow")
    if scan is None or follow is None:
        raise ValueError("channels that follow the beam need a manifest whose antenna turns and whose pattern "
                         "falls to assign_below_db (sidelobe_db at or below it)")
    common, values = _channel_values(manifest, contract, target, rows=True)
    chans = manifest["registers"]["channels"]
    words = _load_streams(manifest, stream_dir, streams, values)
    if words is None:
        raise ValueError("following needs the streams (the manifest's folder)")
    # the rolled regions: a shared one holds every member's words from its
    # offset for 2N - 1 words (the period continued)
    regions, placed, at, bases = [], {}, 0, []
    for k, ch in enumerate(chans):
        n = len(words[k])
        region = ch.get("pool_region")
        key, offset, size = ((region["stream"], int(region["offset"]), int(region["words"]) + n - 1)
                             if region else (("own", k), 0, 2 * n - 1))
        if key not in placed:
            placed[key] = (at, [None] * size)
            at += size
        base, content = placed[key]
        for i in range(2 * n - 1):
            content[offset + i] = int(words[k][i % n]) & 0xFFFFFFFF
        bases.append(base + offset)
    if at > contract.pool_words:
        raise ValueError(f"the rolled streams need {at} words together but the stream pool holds "
                         f"{contract.pool_words}")
    regions = [(base, [0 if w is None else w for w in content]) for base, content in placed.values()]
    rows = sorted((FollowRow(v["azimuth"], v["gain"], v["delay"], bases[k], v["length"], v["inc"])
                   for k, v in enumerate(values)), key=lambda r: r.azimuth)
    table = [int(w) for w in pack_rows(rows)]
    beam = SimpleNamespace(mode=scan["scan_mode"], acp_per_rev=scan["acp_per_rev"], rpm=float(scan["scan_rpm"]))
    guard = follow_guard_codes(beam, contract, contract.channels)
    lo, hi = int(follow["lo"]), int(follow["hi"])
    width = hi + 1 - lo + guard
    if width >= AZIMUTH_CODES:
        raise ValueError(f"the window with its guard ({width} codes) spans the whole revolution")
    rmap = register_map(contract)
    a = rmap.addr
    zeroed = {**scan, "pattern": {**scan["pattern"], "words": list(follow["words"]), "floor": 0}}
    load, scan_start = scan_writes(rmap, zeroed)
    stop = [(a("FOLLOW_CTRL"), 0)] + [(a("CTRL", ch), 0) for ch in range(contract.channels)]
    settings = load + [(a("COMMON_DELAY"), common), (a("APPLY"), 1),
                       (a("FOLLOW_WINDOW"), (lo - guard) % AZIMUTH_CODES | ((hi + 1) % AZIMUTH_CODES) << 16),
                       (a("FOLLOW_SPAN"), width | guard << 16)]
    settings += [w for ch in range(contract.channels) for w in ((a("GAIN", ch), 0), (a("CTRL", ch), CTRL_ENABLE))]
    rows_field = rmap.reg("FOLLOW_CTRL").field("rows")
    start = scan_start + [(a("FOLLOW_CTRL"), 1 | len(rows) << rows_field.lsb | 1 << 31)]
    return FollowLoad(regions, table, rows, stop, settings, start, guard)


def follow_register_writes(load: FollowLoad, rmap: RegisterMap) -> list:
    """:class:`FollowLoad` as one list of writes (the streams, the table, then
    the settings and the start), for a loader that checks nothing between."""
    a = rmap.addr
    w = list(load.stop)
    for base, words in load.regions:
        w += [(a("STREAM_ADDR"), base)] + [(a("STREAM_DATA"), x) for x in words]
    w += [(a("TABLE_ADDR"), 0)] + [(a("TABLE_DATA"), x) for x in load.table]
    return w + load.settings + load.start
