"""The antenna scan inside the engine (WindFarmReplay built with ``scan``) in
the Amaranth simulator against the bit-exact model: the pattern table loaded
through the bus, the free-running beam, and the beam following ACP/ARP pulses
with jitter, glitches and a missing ARP."""

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.fixedpoint import pack_iq, take_interval
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.regmap import SCAN_RESTART, stream_crc32
from rast.model.contract.scan import PATTERN_ONE

from rast.sim.scan_drive import radar_pulses

from hdl_harness import run_replay, model_replay, assert_same, assert_reads

KW = dict(pool_words=256, max_delay=20, max_tap=6, interpolation="hold", scan=True)
#: A short filter keeps the ACP trains of a few thousand clocks (the board's is 16).
FILTER = 4


def inits_for(rng, n, azimuths):
    """Channels playing short random streams at a strong gain, at ``azimuths`` (codes)."""
    out, base = [], 0
    for l in range(n):
        length = int(rng.integers(2, 9))
        words = pack_iq(rng.integers(-20000, 20000, length), rng.integers(-20000, 20000, length))
        out.append(ChannelInit(tuple(int(w) for w in words), int(rng.integers(0, 1 << 30)),
                               int(rng.integers(1 << 15, 1 << 16)), int(rng.integers(0, 7)), True, base,
                               azimuth=int(azimuths[l])))
        base += length
    return out


def pattern_ops(rmap, words, first, shift, floor, at=0):
    """Writes of the pattern: PATTERN, PATTERN_ADDR = first, the words, then a
    read of PATTERN_CRC."""
    ops = [(at, "w", rmap.addr("PATTERN"), shift | floor << 16), (at, "w", rmap.addr("PATTERN_ADDR"), first)]
    ops += [(at, "w", rmap.addr("PATTERN_DATA"), int(w)) for w in words]
    return ops + [(at, "r", rmap.addr("PATTERN_CRC"), 0)]


def check_scan(dut, inits, T, ops, pulses=(), seed=0, name="scan"):
    xi, xq = check_inputs(seed, T)
    hi, hq, done = run_replay(dut, xi, xq, ops, pulses=pulses)
    mi, mq, reads, model = model_replay(dut.contract, inits, xi, xq, done, dut.init_common_delay)
    assert_same(name, xi, xq, hi, hq, mi, mq)
    assert_reads(name, reads)
    return hi, hq, done, reads, model


def steps_per_access(slots):
    return -(-take_interval(slots) // slots)


@pytest.mark.parametrize("slots", [1, 2, 4])
def test_the_free_beam_sweeps_the_pattern_over_each_channel_bit_exact(slots):
    """Four channels 100 codes apart; the beam one code a step (a revolution
    of 2**16 samples) sweeps a random 160-word part of the table (shift 0)
    over them, stops (stare) and turns back anticlockwise: every output
    sample equals the model's; the table's CRC and the beam read back as the
    host computes them; and the scan changes the echo (the same run with the
    scan left in stare differs)."""
    rng = np.random.default_rng(slots)
    az = [40000 + 40 * l for l in range(4)]
    inits = inits_for(rng, 4, az)
    dut = WindFarmReplay(4, slots=slots, init=inits, acp_filter_clocks=FILTER, **KW)
    rmap = dut.register_map
    words = rng.integers(1, PATTERN_ONE + 1, 160)
    ops = pattern_ops(rmap, words, 512 - 80, 0, 77)
    ops += [(0, "w", rmap.addr("SCAN_PERIOD"), 1 << 16), (0, "w", rmap.addr("SCAN_START"), az[0] - 60)]
    s0 = (len(ops) + 4) * steps_per_access(slots)        # the load is done
    scan = [(s0, "w", rmap.addr("SCAN_CTRL"), 1 | SCAN_RESTART),
            (s0 + 200, "r", rmap.addr("SCAN_STATUS"), 0),
            (s0 + 260, "w", rmap.addr("SCAN_CTRL"), 0), (s0 + 300, "w", rmap.addr("SCAN_CTRL"), 1 | 4),
            (s0 + 350, "r", rmap.addr("AZIMUTH", 2), 0)]
    T = s0 + 420
    hi, hq, done, reads, model = check_scan(dut, inits, T, ops + scan, seed=slots, name=f"free M={slots}")
    crc_read = next(r for r in reads if r[1] == rmap.addr("PATTERN_CRC"))
    assert crc_read[3] == stream_crc32(words)
    restart = next(d[0] for d in done if d[1] == "w" and d[2] == rmap.addr("SCAN_CTRL"))
    k, _, _, beam = next(r for r in reads if r[1] == rmap.addr("SCAN_STATUS"))
    assert beam == az[0] - 60 + (k - restart), "the free beam is not one code a step from SCAN_START"
    staring = [d if d[1] != "w" or d[2] != rmap.addr("SCAN_CTRL") else (d[0], "w", d[2], 0) for d in done]
    si, sq, _, _ = model_replay(dut.contract, inits, *check_inputs(slots, T), staring)
    assert (si != hi).any() or (sq != hq).any(), "the scan did not change the echo"


def check_inputs(seed, T):
    rng = np.random.default_rng(seed)
    return rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)


@pytest.mark.slow
def test_the_beam_follows_acp_and_arp_with_jitter_a_glitch_and_a_missing_arp():
    """acp mode, 256 ACPs a revolution learned ("auto") from two ARPs, then
    a revolution whose ARP is missing (ARP-lost read in STATUS, the beam
    going on at the learned count), glitches on both pins shorter than the
    filter, each ACP moved by up to 2 clocks: bit-exact with the model, which
    is told only the pulses the filter passes."""
    rng = np.random.default_rng(7)
    az = [0, 30, 65536 - 40, 200]
    inits = inits_for(rng, 4, az)
    dut = WindFarmReplay(4, slots=2, init=inits, acp_filter_clocks=FILTER, **KW)
    rmap = dut.register_map
    words = rng.integers(1, PATTERN_ONE + 1, 1024)
    ops = pattern_ops(rmap, words, 0, 4, 300)           # 16 codes a word: +-8192 codes
    ops += [(0, "w", rmap.addr("SCAN_CTRL"), 2 | 8 | SCAN_RESTART)]
    spacing, n, t0 = 24, 256, 9000                      # t0: after the table's writes
    pulses = radar_pulses(rng, t0, n, 4, spacing, 2, FILTER + 2, missing=(3,), glitch=FILTER - 1)
    T = (t0 + 4 * n * spacing + 40 * spacing) // 2
    status = [(k, "r", rmap.addr(name), 0) for k in range(T // 10, T, T // 10)
              for name in ("STATUS", "SCAN_STATUS", "ACP_PER_REV")]
    hi, hq, done, reads, model = check_scan(dut, inits, T, ops + status, pulses, seed=3, name="acp")
    per_rev = [r for r in reads if r[1] == rmap.addr("ACP_PER_REV")]
    assert per_rev[-1][3] == n, "the count per revolution was not learned"
    lost = [r[3] >> 2 & 1 for r in reads if r[1] == rmap.addr("STATUS")]
    assert 1 in lost, "the missing ARP was not flagged"
