"""A scene for a replay block whose channels follow the beam, and the model
it must match: the accesses that load the scene (rolled streams, the turbine
table, the zeroed pattern, the window, the channels, the start), and the
bit-exact model with one channel per turbine (each switched in at the
scene's start at the phase it then has), fed the same global accesses.
Shared by the Amaranth-simulator test (``tests/test_hdl_follow_engine.py``)
and the cocotb testbench (``rast.sim.tb_follow``).

An access is ``(step, "w"|"r", addr, value)`` as ``rast.sim.scan_drive``'s;
the block's accesses done (``k`` the step each landed before) give the step
the scene started at.
"""

from __future__ import annotations

import numpy as np

from rast.model.contract.fixedpoint import PHASE_FRAC_BITS, ReplayContract, pack_iq
from rast.model.contract.follow import FollowRow, follow_guard_codes, follow_pattern, follow_phase, pack_rows
from rast.model.contract.regmap import CTRL_ENABLE, SCAN_RESTART, follow_switch_word, register_map
from rast.model.contract.scan import AZIMUTH_CODES, pattern_words
from rast.sim.scan_drive import model_replay

__all__ = ["follow_scene", "scene_start", "reference_contract", "follow_reference"]


def reference_contract(contract: ReplayContract, turbines: int) -> ReplayContract:
    """The block of one channel per turbine the following block must match."""
    return ReplayContract(channels=turbines, slots=contract.slots, pool_words=contract.pool_words,
                          max_delay=contract.max_delay, max_tap=contract.max_tap,
                          interpolation=contract.interpolation, sample_rate_hz=contract.sample_rate_hz,
                          scan=True, start_frac=True)


def follow_scene(rng, contract: ReplayContract, scan, azimuths, *, stream_words=(6, 11), sweep_start: int = 60):
    """The accesses that load a scene of turbines at ``azimuths`` (codes,
    sorted) into a following block: random streams (lengths in
    ``stream_words``; increments both the block and the one-per-turbine
    model take), gains and taps. Returns a dict: ``ops`` (at step 0, the
    start last: the block lands them in order), ``rows``, ``bases``,
    ``window``, ``guard``, ``start_code`` (the beam's start, ``sweep_start``
    codes before the first turbine takes a channel)."""
    rmap = register_map(contract)
    a = rmap.addr
    ref = reference_contract(contract, len(azimuths))
    window = follow_pattern(scan, pattern_words(scan))
    guard = follow_guard_codes(scan, contract, contract.channels)
    width = window.hi + 1 - window.lo + guard
    top = min(contract.max_phase_increment, ref.max_phase_increment)
    ops, base, rows = [], 0, []
    for az in azimuths:
        n = int(rng.integers(*stream_words))
        words = [int(w) for w in pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))]
        rolled = words + words[:-1]            # any phase plays from base + its whole words
        ops += [(0, "w", a("STREAM_ADDR"), base)] + [(0, "w", a("STREAM_DATA"), w) for w in rolled]
        rows.append(FollowRow(int(az), int(rng.integers(1 << 15, 1 << 16)), int(rng.integers(0, contract.max_tap)),
                              base, n, int(rng.integers(top // 4, top + 1))))
        base += len(rolled)
    table = pack_rows(rows)
    ops += [(0, "w", a("TABLE_ADDR"), 0)] + [(0, "w", a("TABLE_DATA"), int(w)) for w in table]
    ops += [(0, "r", a("TABLE_CRC"), 0)]
    kept = np.flatnonzero(window.table.words)
    ops += [(0, "w", a("PATTERN"), 0), (0, "w", a("PATTERN_ADDR"), int(kept[0]))]
    ops += [(0, "w", a("PATTERN_DATA"), int(w)) for w in window.table.words[kept[0]:kept[-1] + 1]]
    start_code = (int(azimuths[0]) + window.lo - guard - sweep_start) % AZIMUTH_CODES
    ops += [(0, "w", a("SCAN_PERIOD"), AZIMUTH_CODES), (0, "w", a("SCAN_START"), start_code),
            (0, "w", a("FOLLOW_WINDOW"), (window.lo - guard) % AZIMUTH_CODES | ((window.hi + 1) % AZIMUTH_CODES) << 16),
            (0, "w", a("FOLLOW_SPAN"), width | guard << 16)]
    ops += [(0, "w", a("CTRL", l), CTRL_ENABLE) for l in range(contract.channels)]
    ops += [(0, "w", a("SCAN_CTRL"), 1 | SCAN_RESTART),
            (0, "w", a("FOLLOW_CTRL"), 1 | len(rows) << rmap.reg("FOLLOW_CTRL").field("rows").lsb | 1 << 31)]
    return dict(ops=ops, rows=rows, table=table, window=window, guard=guard, width=width, start_code=start_code)


def scene_start(contract: ReplayContract, done) -> int:
    """The step the scene started at: the one FOLLOW_CTRL's start landed before."""
    addr = register_map(contract).addr("FOLLOW_CTRL")
    return next(k for k, kind, at, value in done if kind == "w" and at == addr and value >> 31)


def follow_reference(contract: ReplayContract, rows, done, xi, xq):
    """The output of the model with one channel per turbine: the block's
    global writes (streams, pattern, scan; not its following's) at the steps
    they landed, and from the scene's start each turbine's channel switched
    in (FOLLOW_SWITCH, one at a time: turbine l at the scene's step 2l + 1)
    at the phase it has when the switch's refill is over (its stream from
    step 0 of the scene), enabled. The scene must leave every turbine out of
    the window for its first 2·turbines + refill steps. Returns ``(yi, yq)``."""
    k0 = scene_start(contract, done)
    rmap = register_map(contract)
    ref = reference_contract(contract, len(rows))
    rref = register_map(ref)
    shared = [d for d in done if d[1] == "w" and rmap.by_addr(d[2]).channel is None
              and rref.by_addr(d[2]) is not None and not rmap.by_addr(d[2]).name.startswith(("FOLLOW", "TABLE"))]
    loads = []
    for l, r in enumerate(rows):
        at, switch = k0 + 2 * l, k0 + 2 * l + 1        # (one switch held at a time: each fires first)
        phase = follow_phase(switch - k0 + ref.refill_samples, r.phase_inc, r.length)
        for name, value in (("AZIMUTH", r.azimuth), ("GAIN", r.gain), ("DELAY", r.delay), ("LENGTH", r.length),
                            ("PHASE_INC", r.phase_inc), ("BASE", r.base + (phase >> PHASE_FRAC_BITS)),
                            ("START", phase & 0xFFFFFFFF)):
            loads.append((at, "w", rref.addr(name, l), value))
        loads += [(at, "w", rref.addr("FOLLOW_SWITCH"), follow_switch_word(rref, l, switch)),
                  (at, "w", rref.addr("CTRL", l), CTRL_ENABLE)]
    loads.append((k0 + 2 * (len(rows) - 1), "w", rref.addr("APPLY"), 1))        # (every DELAY in)
    yi, yq, _, _ = model_replay(ref, [], xi, xq, sorted(shared + loads, key=lambda d: d[0]))
    return yi, yq
