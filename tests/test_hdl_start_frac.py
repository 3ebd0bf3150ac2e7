"""A stream switched in at a fraction of its first word (``start_frac``, the
START register: what a channel that follows the beam needs) in the
Amaranth simulator against the bit-exact model, for every interpolation:
channels disabled and switched at once, and switched at their period's end."""

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.fixedpoint import pack_iq, take_interval
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP, follow_switch_word, stream_crc32

from hdl_harness import run_replay, model_replay, assert_same, assert_reads


def _inits(rng, n, lengths):
    out, base = [], 0
    for l in range(n):
        words = pack_iq(rng.integers(-20000, 20000, lengths[l]), rng.integers(-20000, 20000, lengths[l]))
        out.append(ChannelInit(tuple(int(w) for w in words), int(rng.integers(1 << 26, 1 << 29)),
                               int(rng.integers(1 << 15, 1 << 16)), int(rng.integers(0, 4)), True, base))
        base += lengths[l]
    return out, base


def _load(rmap, l, at, base, words, inc, start, *, enable):
    """The writes that switch channel ``l`` to ``words`` at ``base`` starting
    ``start`` into word 0 (disabled: at once; enabled: at its period's end)."""
    ops = [(at, "w", rmap.addr("STREAM_ADDR"), base)]
    ops += [(at, "w", rmap.addr("STREAM_DATA"), int(w)) for w in words]
    ops += [(at, "w", rmap.addr("BASE", l), base), (at, "w", rmap.addr("LENGTH", l), len(words)),
            (at, "w", rmap.addr("CRC", l), stream_crc32(words)), (at, "w", rmap.addr("PHASE_INC", l), inc),
            (at, "w", rmap.addr("START", l), start)]
    if not enable:
        ops.append((at, "w", rmap.addr("CTRL", l), 0))
    ops += [(at, "w", rmap.addr("CTRL", l), CTRL_SWAP | (CTRL_ENABLE if enable else 0))]
    if not enable:
        ops.append((at + 40, "w", rmap.addr("CTRL", l), CTRL_ENABLE))
    return ops + [(at + 60, "r", rmap.addr("START", l), 0)]


@pytest.mark.parametrize("interpolation, slots", [("fir", 2), ("fir", 4), ("linear", 1), ("hold", 2)])
def test_a_stream_starts_at_its_start_fraction_bit_exact(interpolation, slots):
    rng = np.random.default_rng(slots + len(interpolation))
    lengths = [24, 30, 20, 26]
    inits, used = _inits(rng, 4, lengths)
    dut = WindFarmReplay(4, slots=slots, pool_words=512, max_delay=20, max_tap=6, interpolation=interpolation,
                         scan=True, start_frac=True, init=inits)
    rmap = dut.register_map
    per_access = -(-take_interval(slots) // slots)
    ops, at, base = [], 20, used
    for l, enable in ((0, False), (1, True), (2, False), (3, False)):
        n = int(rng.integers(12, 18))            # (short: the starts are the subject)
        words = pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))
        top = dut.contract.max_phase_increment
        start, inc = int(rng.integers(1, 1 << 32)), int(rng.integers(top // 4, top + 1))
        if l == 3:      # the first step crosses into the next word (a FIR phase step from the low part's carry)
            start = (1 << 32) - int(rng.integers(1, inc))
        load = _load(rmap, l, at, base, words, inc, start, enable=enable)
        ops += load
        at += (len(load) + 6) * per_access + 80
        base += n
    ops.append((at, "r", rmap.addr("CONFIG"), 0))
    T = at + 300
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, hq, done = run_replay(dut, xi, xq, ops)
    mi, mq, reads, model = model_replay(dut.contract, inits, xi, xq, done, dut.init_common_delay)
    assert_same(f"start {interpolation} M={slots}", xi, xq, hi, hq, mi, mq)
    assert_reads(f"start {interpolation} M={slots}", reads)
    config = next(r[3] for r in reads if r[1] == rmap.addr("CONFIG"))
    assert config >> 23 & 1, "CONFIG does not say the channels have START"
    starts = [r[3] for r in reads if r[1] in [rmap.addr("START", l) for l in range(4)]]
    assert len(starts) == 4 and all(starts)
    # START changes the echo: the same writes with START at 0 play otherwise
    zero = [d if d[1] != "w" or d[2] not in [rmap.addr("START", l) for l in range(4)] else (d[0], "w", d[2], 0)
            for d in done]
    zi, zq, _, _ = model_replay(dut.contract, inits, xi, xq, zero, dut.init_common_delay)
    assert (zi != hi).any() or (zq != hq).any()


def test_the_loader_reads_start_frac_from_config():
    """CONFIG's bit 23 (only in a build with START): what `rast load` reads
    the block as, so that it writes START where there is one."""
    from rast.load import _read_contract
    from rast.model.contract.fixedpoint import ReplayContract
    from rast.model.contract.hostproto import BRIDGE_ID
    from rast.model.contract.regmap import register_map

    for start_frac in (False, True):
        contract = ReplayContract(channels=64, slots=8, scan=True, start_frac=start_frac, sample_rate_hz=20_000_000)
        rmap = register_map(contract)

        class Board:
            def version(self):
                return BRIDGE_ID

            def read(self, addr):
                return sum(f.reset << f.lsb for f in rmap.by_addr(addr).fields if f.access == "ro")

        assert _read_contract(Board()) == contract
    with pytest.raises(ValueError, match="start_frac needs scan"):
        ReplayContract(start_frac=True)


@pytest.mark.slow
@pytest.mark.parametrize("interpolation, slots, valid", [("fir", 4, (1, 1, 0)),
                                                         ("linear", 1, (1, 0, 1, 1)), ("hold", 8, (1,))])
def test_a_switch_at_a_named_step_bit_exact(interpolation, slots, valid):
    """FOLLOW_SWITCH: channels switched by force (enabled or not, no SWAP
    check) at a step named by its low 12 bits, some steps after the write,
    the very next step, and one replaced before its step; with gaps in the
    input: bit-exact with the model, and the switch is at its step (a step
    earlier or later plays otherwise)."""
    rng = np.random.default_rng(slots * 7 + len(valid))
    inits, used = _inits(rng, 4, [24, 30, 20, 26])
    dut = WindFarmReplay(4, slots=slots, pool_words=512, max_delay=20, max_tap=6, interpolation=interpolation,
                         scan=True, start_frac=True, init=inits)
    rmap = dut.register_map
    per_access = -(-take_interval(slots) // slots) * len(valid)
    top = dut.contract.max_phase_increment
    ops, at, base, plan = [], 10, used, []
    for l, lead in ((0, 37), (1, 1), (2, 200), (3, 90), (2, 12)):
        n = int(rng.integers(12, 18))            # (short: the switches are the subject)
        words = pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))
        ops += [(at, "w", rmap.addr("STREAM_ADDR"), base)]
        ops += [(at, "w", rmap.addr("STREAM_DATA"), int(w)) for w in words]
        ops += [(at, "w", rmap.addr("BASE", l), base), (at, "w", rmap.addr("LENGTH", l), n),
                (at, "w", rmap.addr("PHASE_INC", l), int(rng.integers(top // 4, top + 1))),
                (at, "w", rmap.addr("START", l), int(rng.integers(0, 1 << 32)))]
        at += (n + 6) * per_access + 4
        plan.append((at, l, lead))
        ops.append((at, "w", rmap.addr("FOLLOW_SWITCH"), follow_switch_word(rmap, l, at + lead)))
        at += 2 * per_access + (lead if lead < 100 else 10) + 20       # channel 2's first switch is replaced
        base += n
    T = at + 200
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    hi, hq, done = run_replay(dut, xi, xq, ops, valid=valid, hold=True)
    mi, mq, reads, model = model_replay(dut.contract, inits, xi, xq, done, dut.init_common_delay)
    assert_same(f"follow switch {interpolation} M={slots}", xi, xq, hi, hq, mi, mq)
    switch_writes = [d for d in done if d[1] == "w" and d[2] == rmap.addr("FOLLOW_SWITCH")]
    assert [d[0] for d in switch_writes] == [p[0] for p in plan]      # (hold: each write at its step)
    for k, (at, l, lead) in enumerate(plan):         # a step off either way plays otherwise
        for shift in (-1, 1):
            if lead >= 100 or lead + shift < 1:
                continue                               # (replaced before its step; the write's own step: a span on)
            word = follow_switch_word(rmap, l, at + lead + shift)
            moved = [d if d is not switch_writes[k] else (d[0], "w", d[2], word) for d in done]
            si, sq, _, _ = model_replay(dut.contract, inits, xi, xq, moved, dut.init_common_delay)
            assert (si != hi).any() or (sq != hq).any(), (k, shift)
