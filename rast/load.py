"""load a `rast stream` manifest (streams, delays, gains) into a board over the UART bridge

``rast load MANIFEST_DIR --port /dev/ttyUSB0`` asks the bitstream for its
configuration (channel count, pool words, delays, latency), writes every
windmill's stream into the stream pool, switches each channel to its stream
(the block takes a switch only if the words it received have the stream's
CRC-32), sets gains and delays, reads them back, checks that no switch was
refused and prints the status (overflow and underflow flags, versions).

The load is live when the new streams fit in the pool beside the ones
playing: no channel is turned off, each new stream goes into free pool space
and each playing channel switches to it at its old stream's next period
boundary (then, as after any switch, it is silent while its word cache
refills); a refused switch leaves the old stream playing. Otherwise
(``--muted``, or no room) every channel is disabled first and the streams
are written from pool address 0, as at start-up.

With ``--verify`` (a bitstream whose pool is in SDRAM) it then reads every
stream back out of the SDRAM and compares its CRC-32.

A manifest whose antenna turns, into a bitstream built with the scan: each
channel's AZIMUTH with the rest, then the pattern table with the scan off
(stare), its CRC-32 read back (PATTERN_CRC) and the table sent again until
it matches, and only then the scan's period, start and mode.
"""

import os
import sys
import time

from rast.errors import UserError, manifest_streams, read_manifest
from rast.model.contract.fixedpoint import INTERPOLATIONS, ReplayContract
from rast.model.contract.hostproto import HostBridge, BRIDGE_ID, DEFAULT_BAUD, ProtocolError, line_bytes
from rast.model.contract.regmap import (ID_VALUE, register_map, stream_crc32, CTRL_ENABLE, CTRL_REJECTED,
                                        APPLIED_LSB)
from rast.model.contract.datapath import ONE
from rast.model.contract.loadplan import (NoRoomBeside, follow_load, manifest_to_register_writes, scan_writes,
                                          pattern_crc)

__all__ = ["add_arguments", "run", "read_contract", "load_manifest", "read_manifest_dir", "plan_writes",
           "send_writes", "read_status", "verify_pool", "stream_runs", "playing_streams", "stream_segments",
           "LoadError", "RETRIES"]

_GLOBAL = register_map(ReplayContract(channels=1))


class LoadError(Exception):
    pass


def read_contract(bridge: HostBridge) -> ReplayContract:
    """The replay block's parameters, read from its capability registers
    twice, alike both times: the protocol's frames carry no check, and a
    damaged address or reply would otherwise size the load by another
    register's value. Read again (after a resynchronisation) when the line
    damaged a reply or the two differ, RETRIES times."""
    for attempt in range(RETRIES + 1):
        try:
            first, second = _read_contract(bridge), _read_contract(bridge)
            if first == second:
                return first
            if attempt == RETRIES:
                raise LoadError("the capability registers read differently twice in a row: "
                                "the line damages frames")
        except (LoadError, ProtocolError, ValueError):
            if attempt == RETRIES:
                raise
        bridge.resync()


def _read_contract(bridge: HostBridge) -> ReplayContract:
    bid = bridge.version()
    if bid != BRIDGE_ID:
        raise LoadError(f"Bridge identifies as {bid:#010x}, this loader speaks {BRIDGE_ID:#010x}")
    a = _GLOBAL.addr
    ident = bridge.read(a("ID"))
    if ident != ID_VALUE:
        raise LoadError(f"Register ID reads {ident:#010x}, not {ID_VALUE:#010x}: not a RAST bitstream")
    cfg = bridge.read(a("CONFIG"))
    c = ReplayContract(channels=(cfg & 0xFF) | (cfg >> 13 & 7) << 8, slots=max(1, cfg >> 16 & 0x7F),
                       pool_words=bridge.read(a("POOL_WORDS")),
                       max_delay=bridge.read(a("MAX_DELAY")),
                       max_tap=bridge.read(a("MAX_TAP")),
                       interpolation=INTERPOLATIONS[min(cfg >> 8 & 3, len(INTERPOLATIONS) - 1)],
                       cmult_form="3mult" if cfg >> 10 & 1 else "4mult",
                       pool="sdram" if cfg >> 11 & 1 else "bram", scan=bool(cfg >> 12 & 1),
                       start_frac=bool(cfg >> 23 & 1),
                       sample_rate_hz=bridge.read(a("SAMPLE_RATE")))
    lat = bridge.read(a("LATENCY"))
    if lat != c.latency:
        raise LoadError(f"Bitstream latency {lat} differs from the model's {c.latency} for "
                        f"{c}: bitstream and host software are of different versions")
    return c


def expected_readback(writes, rmap):
    """Last value written to each read/write register, after clamping."""
    exp = {}
    for addr, value in writes:
        r = rmap.by_addr(addr)
        if (r is None or r.name in ("STREAM_DATA", "APPLY", "STREAM_ADDR", "PATTERN_ADDR")
                or not any(f.access == "rw" for f in r.fields)):
            continue
        v = 0
        for f in r.fields:
            if f.access != "rw":
                continue
            fv = (value >> f.lsb) & ((1 << f.width) - 1)
            if f.clamp:
                fv = min(max(fv, f.clamp[0]), f.clamp[1])
            v |= fv << f.lsb
        exp[addr] = (r, v)
    return exp


def read_manifest_dir(manifest_dir, streams=True):
    """``(manifest, stream words per channel or None)`` from a `rast stream` folder (or
    its manifest.json); a missing or malformed file raises :class:`rast.errors.UserError`."""
    manifest, path = read_manifest(manifest_dir)
    return manifest, (manifest_streams(manifest, path.parent) if streams else None)


def plan_writes(manifest, contract, words=None, playing=None):
    """The register writes of ``manifest`` for a block of ``contract`` (a live
    load beside ``playing``, as :func:`manifest_to_register_writes`; it raises
    :class:`NoRoomBeside`); a manifest that does not fit the block raises
    :class:`rast.errors.UserError` (nothing is sent)."""
    try:
        return manifest_to_register_writes(manifest, contract, streams=words, target="board",
                                           playing=playing, with_scan=False)
    except NoRoomBeside:
        raise
    except ValueError as error:
        raise UserError(f"the manifest does not fit the bitstream's replay block ({contract.channels} "
                        f"channel(s), pool words {contract.pool_words}, maximum delay "
                        f"{contract.max_delay}, maximum tap {contract.max_tap}, latency "
                        f"{contract.latency}): {error}") from None


#: Longest a write to the serial port may block (the board not reading) before
#: ``rast load`` gives up: 3 Mbaud moves a 64 KB burst in 0.2 s.
WRITE_TIMEOUT_S = 5.0
#: The longest ``rast load`` waits for switches an earlier load left pending
#: (each is taken at its old stream's period boundary) before a live load.
PENDING_WAIT_S = 30.0


def playing_streams(bridge, contract, wait=time.sleep, timeout_s=PENDING_WAIT_S):
    """``(regions, switch_s)``: per channel ``(base, length, phase increment)``
    of the stream the block plays, or ``None`` (disabled, or a phase
    increment of 0: it would never reach a period boundary to switch at), and
    the longest period among them (the longest a live switch waits). Waits
    first, polling CTRL, until no switch is pending (the registers then name
    the streams playing); ``(None, None)`` if one still is after ``timeout_s``."""
    a = register_map(contract).addr
    waited = 0.0
    while True:
        ctrl = [bridge.read(a("CTRL", ch)) for ch in range(contract.channels)]
        if not any(c >> 1 & 1 for c in ctrl):
            break
        if waited >= timeout_s:
            return None, None
        wait(0.05)
        waited += 0.05
    regions, switch_s = [], 0.0
    for ch in range(contract.channels):
        inc = bridge.read(a("PHASE_INC", ch)) if ctrl[ch] & CTRL_ENABLE else 0
        if not inc:
            regions.append(None)
            continue
        regions.append((bridge.read(a("BASE", ch)), bridge.read(a("LENGTH", ch)), inc))
        if contract.sample_rate_hz:
            switch_s = max(switch_s, regions[-1][1] * ONE / inc / contract.sample_rate_hz)
    return regions, switch_s


#: Times ``rast load`` sends again what did not take effect (a frame lost or
#: damaged on the line) before it gives up and names what failed.
RETRIES = 2
#: Longest ``rast load`` waits for a switch beyond the longest stream period.
SWITCH_MARGIN_S = 1.0


def load_manifest(bridge, manifest_dir, contract=None, *, streams=True, progress=None, verify=False,
                  wait=time.sleep, live=True):
    """Write the manifest in ``manifest_dir`` into the block, live (beside the
    streams playing, :func:`playing_streams`) when ``live`` and they fit, else
    muted, and see it take effect (:func:`send_writes`): every register read
    back, every switch taken (the channel's bank toggled, its PLAYED CRC the
    stream's), the delays in effect; what did not take effect is sent again,
    RETRIES times. A conversation the line broke (a frame lost or damaged,
    :class:`ProtocolError`) is resynchronised and the load made again, as
    often. With ``verify`` the streams are then read back out of an SDRAM
    pool (:func:`verify_pool`, ``wait`` as there).

    Returns a dict of what was done (``live``: whether the load was, and if
    not, ``muted_why``; ``switch_s``: the longest a playing channel may take
    to reach its switch; ``retries``: what was sent again). Raises
    :class:`rast.errors.UserError` for a missing, malformed or unfitting
    manifest (before any write) and :class:`LoadError` when the block does
    not take the load, naming the channels."""
    manifest, words = read_manifest_dir(manifest_dir, streams)
    contract = contract or read_contract(bridge)
    if verify:
        _require_read_back(contract)                 # before anything is written
    if contract.follow_rows:
        return load_following(bridge, manifest, words, contract)
    plan_writes(manifest, contract, words)           # refuses a manifest that does not fit at all
    for attempt in range(RETRIES + 1):
        try:
            res = _load_once(bridge, manifest, words, contract, progress, wait, live)
            break
        except ProtocolError as error:
            if attempt == RETRIES:
                raise LoadError(f"the line broke the conversation {RETRIES + 1} times (last: {error}); "
                                "the load did not finish: check the cable and load again") from None
            bridge.resync()
    res["line_retries"] = attempt
    if verify:
        res.update(verify_pool(bridge, contract, res.pop("plan"), wait))
    else:
        res.pop("plan")
    return res


def _load_once(bridge, manifest, words, contract, progress, wait, live):
    writes = plan_writes(manifest, contract, words)
    playing, why, switch_s = None, "as --muted asks", 0.0
    if words is not None and live:
        playing, switch_s = playing_streams(bridge, contract, wait)
        why = (f"a switch of an earlier load was still pending after {PENDING_WAIT_S:g} s"
               if playing is None else None)
    if playing is not None:
        try:
            writes = plan_writes(manifest, contract, words, [r and r[:2] for r in playing])
        except NoRoomBeside as no_room:
            playing, why = None, str(no_room)
    res = send_writes(bridge, writes, contract, progress, channels=len(manifest["registers"]["channels"]),
                      playing=playing, wait=wait, switch_s=switch_s)
    if contract.scan:
        scanned = load_scan(bridge, contract, manifest.get("scan"))
        res["retries"] += scanned["retries"]
        writes = writes + scanned["writes"]
    res["line_bytes"] = line_bytes(writes)
    res["plan"] = writes
    if words is not None:
        res["live"] = playing is not None
        res["muted_why"] = why
        res["switch_s"] = switch_s if playing is not None else 0.0
    return res


def _sent_until(bridge, writes, crc_addr, want, what) -> int:
    """Send ``writes`` and read ``crc_addr`` until it is ``want`` (RETRIES
    more times); returns the times sent again."""
    for attempt in range(RETRIES + 1):
        bridge.write_many(writes)
        got = _read_twice(bridge, crc_addr, want)
        if got == want:
            return attempt
    raise LoadError(f"{what} did not arrive intact after {RETRIES + 1} tries (CRC-32 read {got:#010x}, "
                    f"sent {want:#010x}); following stays off. Load again.")


def load_following(bridge, manifest, words, contract) -> dict:
    """A turning manifest into a block whose channels follow the beam
    (``rast.model.contract.loadplan.follow_load``): following off, each
    rolled stream region checked against STREAM_CRC, the turbine table
    against TABLE_CRC and the zeroed pattern against PATTERN_CRC (each sent
    again until it matches, RETRIES times), the window, the delays and the
    channels, then the scan's and the following's start; the settings read
    back. Refused before any write: a manifest that does not fit."""
    try:
        plan = follow_load(manifest, contract, streams=words)
    except ValueError as error:
        raise UserError(f"the manifest does not fit the block: {error}") from None
    rmap = register_map(contract)
    a = rmap.addr
    bridge.write_many(plan.stop)
    retries = []

    def checked(writes, crc_addr, want, what):
        if _sent_until(bridge, writes, crc_addr, want, what):
            retries.append(what)
    for base, region in plan.regions:
        checked([(a("STREAM_ADDR"), base)] + [(a("STREAM_DATA"), w) for w in region], a("STREAM_CRC"),
                stream_crc32(region), f"the stream words at {base}")
    checked([(a("TABLE_ADDR"), 0)] + [(a("TABLE_DATA"), w) for w in plan.table], a("TABLE_CRC"), plan.table_crc,
            "the turbine table")
    pattern = [w for w in plan.settings if rmap.by_addr(w[0]).name.startswith(("PATTERN", "SCAN_CTRL"))]
    checked(pattern, a("PATTERN_CRC"), stream_crc32([v for addr, v in pattern if addr == a("PATTERN_DATA")]),
            "the pattern table")
    rest = [w for w in plan.settings if w not in pattern]
    bridge.write_many(rest)
    bridge.write_many(plan.start)
    wrong = {addr: v for addr, (r, v) in expected_readback(rest + plan.start, rmap).items()
             if bridge.read(addr) & sum(f.mask for f in r.fields if f.access == "rw") != v}
    if wrong:
        raise LoadError("The following's registers read back differently: "
                        + ", ".join(_name(rmap, addr) for addr in wrong))
    return {"following": True, "rows": len(plan.rows), "regions": len(plan.regions), "guard_codes": plan.guard,
            "retries": retries, "line_retries": 0, "live": False, "muted_why": "channels that follow the beam",
            "switch_s": 0.0}


def load_scan(bridge, contract, scan) -> dict:
    """The antenna scan of a manifest (its ``scan``, None: it stares) into a
    block built with the scan: the pattern with the scan off, its CRC-32 read
    back (PATTERN_CRC) and the table sent again until it matches (RETRIES
    times; then the scan stays off and :class:`LoadError` says so), then the
    scan's start, read back. Returns ``writes`` (what was sent last) and
    ``retries``."""
    rmap = register_map(contract)
    a = rmap.addr
    load, start = scan_writes(rmap, scan)
    retried = []
    for attempt in range(RETRIES + 1):
        bridge.write_many(load)
        if scan is None:
            break
        want = pattern_crc(scan)
        got = _read_twice(bridge, a("PATTERN_CRC"), want)
        if got == want:
            break
        retried.append(f"the pattern table (PATTERN_CRC {got:#010x}, sent {want:#010x})")
    else:
        raise LoadError(f"The pattern table did not arrive intact after {RETRIES + 1} tries (PATTERN_CRC "
                        f"{got:#010x}, the table's CRC-32 {want:#010x}); the scan is off (stare). Load again.")
    bridge.write_many(start)
    for attempt in range(RETRIES + 1):
        wrong = {addr: v for addr, (r, v) in expected_readback(load + start, rmap).items()
                 if _read_twice(bridge, addr, v) & sum(f.mask for f in r.fields if f.access == "rw") != v}
        if not wrong:
            break
        if attempt == RETRIES:
            raise LoadError("The scan's registers read back differently after "
                            f"{RETRIES + 1} writes: " + ", ".join(_name(rmap, addr) for addr in wrong))
        retried.append("the scan's settings")
        bridge.write_many(start)
    return {"writes": load + start, "retries": retried}


def _read_twice(bridge, addr, want):
    """The register's value, read again once when it is not ``want`` (a reply
    damaged on the line is not taken for the block's state)."""
    got = bridge.read(addr)
    return got if got == want else bridge.read(addr)


def stream_segments(writes, rmap):
    """``[(channel, start, stop)]``: the stretches ``writes[start:stop]`` that
    each load one stream into its channel (STREAM_ADDR, the words, BASE,
    LENGTH, PHASE_INC, CRC and the channel's writes after them up to the next
    stream or another register), in order."""
    a_addr = rmap.addr("STREAM_ADDR")
    segments, current = [], None
    for k, (addr, _) in enumerate(writes):
        r = rmap.by_addr(addr)
        if addr == a_addr:
            current = [None, k, k + 1]
            segments.append(current)
        elif current is not None and r is not None and (
                r.name == "STREAM_DATA" or (r.channel is not None and current[0] in (None, r.channel))):
            current[0] = r.channel if r.channel is not None else current[0]
            current[2] = k + 1
        else:
            current = None
    return [tuple(seg) for seg in segments if seg[0] is not None]


def send_writes(bridge, writes, contract, progress=None, *, channels=None, playing=None, wait=time.sleep,
                switch_s=0.0):
    """Send ``writes`` and see them take effect, sending again what did not
    (RETRIES times) and raising :class:`LoadError` for what still did not:

    * each stream's STREAM_ADDR is read back before its words go (a damaged
      address would put them over another stream);
    * every register written is read back, and written again where it differs;
    * every switch is taken: once no switch is pending (at most the longest
      period ``switch_s``, and SWITCH_MARGIN_S more), each loaded channel's
      bank has toggled and its PLAYED is the stream's CRC-32; a channel that
      failed (its switch lost, or refused: CTRL.rejected, the words damaged)
      gets its stream again;
    * the delays are in effect (the ``applied`` fields), else APPLY is sent again.

    In a live load (``playing``: per channel its old stream's ``(base,
    length, increment)`` or ``None``) a channel whose switch still fails goes
    on with its old stream, and BASE, LENGTH and PHASE_INC are written back
    to name it (what the next live load reads); otherwise it is disabled, as
    its old words may be overwritten."""
    rmap = register_map(contract)
    a = rmap.addr
    t0 = time.monotonic()
    segments = stream_segments(writes, rmap)
    banks = {ch: bridge.read(a("CTRL", ch)) >> 2 & 1 for ch, _, _ in segments}
    retried = []

    def send_segment(seg):
        for _ in range(RETRIES + 1):
            bridge.write(*seg[0])
            if _read_twice(bridge, seg[0][0], seg[0][1]) == seg[0][1]:
                break
        else:
            raise LoadError(f"STREAM_ADDR does not read back {seg[0][1]} after {RETRIES + 1} writes")
        bridge.write_many(seg[1:])

    # the writes in order, each stream's address checked before its words
    k = 0
    for _, start, stop in segments + [(None, len(writes), len(writes))]:
        bridge.write_many(writes[k:start])
        if start < stop:
            send_segment(writes[start:stop])
        k = stop
        if progress:
            progress(k, len(writes))
    dt = time.monotonic() - t0

    # every register written reads back what was written last
    for attempt in range(RETRIES + 1):
        wrong = {}
        for addr, (r, v) in expected_readback(writes, rmap).items():
            mask = sum(f.mask for f in r.fields if f.access == "rw")
            got = bridge.read(addr) & mask
            if got != v:                  # read again: a reply damaged on the line is no verdict
                got = bridge.read(addr) & mask
            if got != v:
                wrong[addr] = (r, v, got)
        if not wrong or attempt == RETRIES:
            break
        retried += [f"{r.name}[{r.channel}]" if r.channel is not None else r.name for r, _, _ in wrong.values()]
        bridge.write_many([(addr, v) for addr, (r, v, _) in wrong.items()])
    if wrong:
        raise LoadError("Read-back differs after " + f"{RETRIES + 1} writes: " + "; ".join(
            f"{r.name}[{r.channel}] reads {got:#x}, wrote {v:#x}" for r, v, got in wrong.values()))

    # every switch taken: bank toggled, PLAYED the stream's CRC
    crc_of = {ch: next(v for addr, v in writes[start:stop] if addr == a("CRC", ch)) for ch, start, stop in segments}
    failed = {}
    for attempt in range(RETRIES + 1):
        _wait_for_switches(bridge, contract, [ch for ch, _, _ in segments], wait, switch_s)
        failed = {}
        for ch, _, _ in segments:
            ctrl = bridge.read(a("CTRL", ch))
            played = _read_twice(bridge, a("PLAYED", ch), crc_of[ch])
            if ctrl & CTRL_REJECTED:
                failed[ch] = "refused: the words it received differ from the stream"
            elif played != crc_of[ch]:
                failed[ch] = f"not switched: it plays the stream of CRC-32 {played:#010x}"
            elif (ctrl >> 2 & 1) == banks[ch]:
                failed[ch] = "not switched: its bank did not toggle"
        if not failed or attempt == RETRIES:
            break
        for ch, start, stop in segments:
            if ch in failed:
                banks[ch] = bridge.read(a("CTRL", ch)) >> 2 & 1
                retried.append(f"channel {ch}'s stream ({failed[ch]})")
                send_segment(writes[start:stop])
    if failed:
        for ch in failed:
            old = playing[ch] if playing is not None else None
            if old is None:
                bridge.write(a("CTRL", ch), 0)
            else:
                bridge.write_many([(a("BASE", ch), old[0]), (a("LENGTH", ch), old[1]),
                                   (a("PHASE_INC", ch), old[2])])
        raise LoadError(
            "The block did not take the stream of " + ", ".join(
                f"channel {ch} (CRC-32 {crc_of[ch]:#010x}: {why})" for ch, why in failed.items())
            + f" after {RETRIES + 1} tries (a word lost or damaged on the line each time); "
            + ("those channels go on as before the load, with their old streams"
               if playing is not None else "those channels are off (their old streams may be overwritten)")
            + ". Load again.")

    # the delays in effect: APPLY taken
    last = {addr: v for addr, v in writes if getattr(rmap.by_addr(addr), "name", None) in ("DELAY", "COMMON_DELAY")}
    for attempt in range(RETRIES + 1):
        late = [addr for addr, v in last.items()
                if _read_twice(bridge, addr, _applied_word(rmap, addr, v)) >> APPLIED_LSB
                != _field_value(rmap, addr, v)]
        if not late or attempt == RETRIES:
            break
        retried.append("APPLY")
        bridge.write(a("APPLY"), 1)
        bridge.flush()
    if late:
        raise LoadError("The delays did not take effect after " f"{RETRIES + 1} APPLY writes: "
                        + "; ".join(_name(rmap, addr) for addr in late))
    n_words = sum(1 for addr, _ in writes if addr == a("STREAM_DATA"))
    return {"writes": len(writes), "stream_words": n_words, "seconds": dt, "channels": channels,
            "retries": retried}


def _field_value(rmap, addr, value):
    """The delay field of a write to DELAY or COMMON_DELAY, clamped as the block does."""
    f = rmap.by_addr(addr).field("delay")
    v = value >> f.lsb & ((1 << f.width) - 1)
    return min(max(v, f.clamp[0]), f.clamp[1]) if f.clamp else v


def _applied_word(rmap, addr, value):
    v = _field_value(rmap, addr, value)
    return v | v << APPLIED_LSB


def _name(rmap, addr):
    r = rmap.by_addr(addr)
    return r.name if r.channel is None else f"{r.name}[{r.channel}]"


def _wait_for_switches(bridge, contract, channels, wait, switch_s):
    """Poll CTRL until no switch of ``channels`` is pending, at most the
    longest period ``switch_s`` and SWITCH_MARGIN_S more."""
    a = register_map(contract).addr
    waited = 0.0
    # polls 8 times a period (a read is 7 bytes on the line), at most every 50 ms
    step = min(0.05, max(switch_s / 8, 1e-3))
    while any(bridge.read(a("CTRL", ch)) >> 1 & 1 for ch in channels):
        if waited > switch_s + SWITCH_MARGIN_S:
            return
        wait(step)
        waited += step


#: Polls of POOL_CHECK's busy bit, after the longest a read-back may take,
#: before it is given up.
CHECK_POLLS = 100


def stream_runs(writes, rmap) -> list:
    """``[(base, words), ...]``: the streams ``writes`` put in the pool (a
    STREAM_ADDR write and the STREAM_DATA words after it)."""
    a_addr, a_data = rmap.addr("STREAM_ADDR"), rmap.addr("STREAM_DATA")
    runs = []
    for addr, value in writes:
        if addr == a_addr:
            runs.append((value, []))
        elif addr == a_data and runs:
            runs[-1][1].append(value)
    return [(base, words) for base, words in runs if words]


def _require_read_back(contract):
    """The register map of ``contract``, which must have POOL_CHECK (UserError otherwise)."""
    rmap = register_map(contract)
    if not rmap.has("POOL_CHECK"):
        raise UserError("this bitstream's stream pool is block RAM, which has no read-back: every "
                        "stream's CRC-32 is checked by the block as it arrives (build with --sdram "
                        "for a pool that can be read back)")
    return rmap


def verify_pool(bridge, contract, writes, wait=time.sleep) -> dict:
    """Read every stream of ``writes`` back out of an SDRAM pool (POOL_CHECK)
    and compare its CRC-32 with the words sent; :class:`LoadError` naming the
    streams that differ. ``wait(seconds)`` waits the longest a read-back may
    take before the busy bit is polled."""
    rmap = _require_read_back(contract)
    a = rmap.addr
    t0 = time.monotonic()
    bad, n_words = [], 0
    for base, words in stream_runs(writes, rmap):
        bridge.write(a("STREAM_ADDR"), base)
        bridge.write(a("POOL_CHECK"), len(words))
        wait(contract.pool_check_seconds(len(words)))
        for _ in range(CHECK_POLLS):
            if not bridge.read(a("POOL_CHECK")) >> 31:
                break
            wait(0.01)
        else:
            raise LoadError(f"the read-back of the stream at pool address {base} did not finish: "
                            "is the SDRAM initialised (LED 2)?")
        got, want = bridge.read(a("POOL_CHECK_CRC")), stream_crc32(words)
        if got != want:
            bad.append(f"{len(words)} words at {base} (CRC-32 {got:#010x}, sent {want:#010x})")
        n_words += len(words)
    if bad:
        raise LoadError("The SDRAM returns other words than were written for the streams of "
                        + "; ".join(bad) + ": the words arrived intact (the block checked their CRC-32) "
                        "but were not stored right; check the SDRAM clock phase (docs/sdram.md)")
    return {"verified_words": n_words, "verify_seconds": time.monotonic() - t0}


def read_status(bridge, contract):
    rmap = register_map(contract)
    status = bridge.read(rmap.addr("STATUS"))           # one read: it clears both flags
    st = {"bridge_id": bridge.version(), "id": bridge.read(rmap.addr("ID")),
          "config": bridge.read(rmap.addr("CONFIG")), "latency": bridge.read(rmap.addr("LATENCY")),
          "overflow": status & 1, "underflow": status >> 1 & 1, "channels": []}
    for ch in range(contract.channels):
        ctrl = bridge.read(rmap.addr("CTRL", ch))
        st["channels"].append({"enable": ctrl & CTRL_ENABLE, "swap_pending": ctrl >> 1 & 1,
                               "bank": ctrl >> 2 & 1, "rejected": ctrl >> 3 & 1,
                               "gain": bridge.read(rmap.addr("GAIN", ch)),
                               "delay": bridge.read(rmap.addr("DELAY", ch)) >> APPLIED_LSB,
                               "played": bridge.read(rmap.addr("PLAYED", ch))})
    return st


def add_arguments(p):
    p.add_argument("manifest_dir", nargs="?", help="folder written by `rast stream` (manifest.json, *.hex), or its manifest.json")
    p.add_argument("--port", required=True, help="serial port of the board, e.g. /dev/ttyUSB0")
    p.add_argument("--baud", type=int, default=DEFAULT_BAUD,
                   help=f"bridge baud rate (default {DEFAULT_BAUD}: the FT231X's fastest; give the "
                        "bitstream's, `rast build --baud`)")
    p.add_argument("--no-streams", action="store_true",
                   help="write gains and delays only, not the streams")
    p.add_argument("--verify", action="store_true",
                   help="then read every stream back out of the SDRAM and compare its CRC-32 (an "
                        "SDRAM bitstream's; a bring-up check of the SDRAM clock phase)")
    p.add_argument("--muted", action="store_true",
                   help="disable every channel during the load and write the streams from pool "
                        "address 0 (the default is live when the new streams fit beside the playing "
                        "ones: each channel switches at its old stream's period boundary)")
    p.add_argument("--status", action="store_true", help="only read and print the status")


def _print_status(st):
    print(f"bridge {st['bridge_id']:#010x}, ID {st['id']:#010x}, CONFIG {st['config']:#x}, "
          f"latency {st['latency']} samples, overflow {'SET' if st['overflow'] else 'clear'}"
          + (", underflow SET (a stream word came later than the contract's fetch bound)"
             if st["underflow"] else ""))
    for k, ch in enumerate(st["channels"]):
        print(f"  channel {k}: {'on ' if ch['enable'] else 'off'} bank {ch['bank']} "
              f"gain {ch['gain']:#07x} delay {ch['delay']} stream CRC-32 {ch['played']:#010x}"
              f"{' (swap pending)' if ch['swap_pending'] else ''}"
              f"{' (last switch refused: stream CRC-32)' if ch['rejected'] else ''}")


def run(args) -> int:
    """Mistakes in the arguments or the manifest (also one that does not fit the
    bitstream) and a port that cannot be opened raise :class:`rast.errors.UserError`
    before anything is written to the board; a failing board or line exits 1."""
    import serial
    if not args.status and not args.manifest_dir:
        raise UserError("give MANIFEST_DIR (or --status)")
    if args.baud <= 0:
        raise UserError(f"--baud must be a positive number of bit/s, not {args.baud}")
    if not args.status:          # a bad manifest is refused before the port is opened
        read_manifest_dir(args.manifest_dir, streams=not args.no_streams)
    try:
        port = serial.Serial(args.port, args.baud, timeout=1.0, write_timeout=WRITE_TIMEOUT_S)
    except (serial.SerialException, ValueError) as error:   # ValueError: a rate the port refuses
        why = os.strerror(error.errno) if getattr(error, "errno", None) else str(error)
        raise UserError(f"cannot open the serial port {args.port}: {why}") from None
    try:
        with port:
            bridge = HostBridge(port)
            bridge.resync(drain=port.reset_input_buffer)
            contract = read_contract(bridge)
            if not args.status:
                def progress(done, total):
                    if done == total or done % 2048 == 0:
                        print(f"\r  {done}/{total} writes", end="", flush=True)
                res = load_manifest(bridge, args.manifest_dir, contract, streams=not args.no_streams,
                                    progress=progress, verify=args.verify, live=not args.muted)
                rate = res["stream_words"] / res["seconds"] if res["seconds"] > 0 else 0.0
                print(f"\nloaded {res['channels']} windmill(s), {res['stream_words']} stream words "
                      f"in {res['seconds']:.1f} s ({rate / 1e3:.1f} k words/s, "
                      f"{res['line_bytes'] * 10 / args.baud:.1f} s of line time at {args.baud} baud); "
                      f"every register reads back what was written, every switch taken (bank toggled, "
                      f"PLAYED = the stream's CRC-32, checked by the block), the delays in effect")
                if res["retries"] or res["line_retries"]:
                    print(f"sent again after the line lost or damaged them: "
                          f"{', '.join(res['retries']) or ''}"
                          + (f"{'; ' if res['retries'] else ''}the whole load {res['line_retries']} time(s)"
                             if res["line_retries"] else ""))
                if res.get("live"):
                    refill = contract.refill_samples
                    print(f"live: no channel turned off; each playing channel switches at its old "
                          f"stream's next period boundary, within {res['switch_s']:.2f} s, then refills "
                          f"its word cache for {refill} samples"
                          + (f" ({refill / contract.sample_rate_hz * 1e3:.2f} ms)" if contract.sample_rate_hz else ""))
                elif "live" in res:
                    print(f"muted: every channel was off during the load ({res['muted_why']})")
                if args.verify:
                    print(f"read {res['verified_words']} stream words back out of the SDRAM in "
                          f"{res['verify_seconds']:.1f} s: every stream's CRC-32 matches")
            _print_status(read_status(bridge, contract))
    except serial.SerialTimeoutException:
        print(f"rast load: the board stopped reading: nothing could be written to {args.port} for "
              f"{WRITE_TIMEOUT_S:g} s; the load did not finish (reset the board, load again)", file=sys.stderr)
        return 1
    except (LoadError, ProtocolError, ValueError, OSError) as e:
        print(f"rast load: {e}", file=sys.stderr)
        return 1
    return 0
