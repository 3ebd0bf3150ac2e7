"""The antenna scan's gateware units in the Amaranth simulator, clock by
clock against the contract (``rast.model.contract.scan``): the ACP/ARP
input's filter, the beam's generator (free running, following fixed and
learned ACP counts, a missing ARP) and a pipeline's pattern gain."""

import random

import numpy as np
import pytest
from amaranth.sim import Simulator

from rast.hdl.acp_input import AcpInput
from rast.hdl.pipeline.pattern_gain import PatternGain
from rast.hdl.scan_generator import ScanGenerator, SCAN_MODES, ACP_MIN_CLOCKS
from rast.model.contract import scan as sc
from rast.model.physics.antenna import AntennaScan


def simulate(dut, bench):
    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


# ------------------------------------------------------------------ the input


@pytest.mark.parametrize("k", [1, 4, 16])
def test_acp_input_passes_pulses_and_drops_glitches(k):
    """A pulse held k clocks or more gives one strobe, latency 2 + k clocks
    after its rising edge; a glitch of fewer than k clocks gives none."""
    dut = AcpInput(k)
    rng = random.Random(k)
    pin, events = [], []
    while len(pin) < 3000:
        gap, width = rng.randrange(k + 3, 4 * k + 20), rng.randrange(1, 3 * k + 4)
        pin += [0] * gap
        if width >= k:
            events.append(len(pin))
        pin += [1] * width
    pin += [0] * (k + 10)
    rises = []

    async def bench(ctx):
        for clock, level in enumerate(pin):
            ctx.set(dut.pin, level)
            await ctx.tick()
            if ctx.get(dut.rise):
                rises.append(clock + 1 - dut.latency)

    simulate(dut, bench)
    assert rises == events and len(events) > 20


@pytest.mark.parametrize("bad", [0, 5000, 2.0, True])
def test_acp_input_names_its_parameter(bad):
    with pytest.raises(ValueError, match="filter_clocks"):
        AcpInput(bad)


# ------------------------------------------------------------------ the generator


def settings(dut, ctx, mode, *, anticlockwise=0, auto=0, acp_log2=12, period=1 << 20, start=0):
    s = dut.settings
    for name, value in (("mode", SCAN_MODES[mode]), ("anticlockwise", anticlockwise), ("auto", auto),
                        ("acp_log2", acp_log2), ("period", period), ("start", start)):
        ctx.set(getattr(s, name), value)


@pytest.mark.parametrize("rpm, fs, start_deg, spacing", [(12_500.0, 20e6, 359.9, 1), (-5_000.0, 20e6, 0.05, 3),
                                                         (2_000.0, 2.5e6, 90.0, 8), (-12_500.0, 20e6, 0.1, 2)])
def test_free_beam_is_the_contracts(rpm, fs, start_deg, spacing):
    """Steps accepted every ``spacing`` clocks: each step's beam is
    free_beam_codes', carrying into the code once in 1.5 to 12 samples (a
    fast turn, so that a short run passes north: P of 96 000 to 240 000).
    From two clocks the generator works the next remainder out ahead; the
    first step is a clock after the restart."""
    p = sc.samples_per_revolution(rpm, fs)
    dut = ScanGenerator(step_clocks=spacing)
    steps = 5000
    got = []

    async def bench(ctx):
        settings(dut, ctx, "free", anticlockwise=int(rpm < 0), period=p, start=int(sc.azimuth_code(start_deg)))
        ctx.set(dut.restart, 1)
        await ctx.tick()
        ctx.set(dut.restart, 0)
        for n in range(steps):
            for k in range(spacing):
                ctx.set(dut.accept, k == 0)
                if k == 0:
                    got.append(ctx.get(dut.beam))
                await ctx.tick()

    simulate(dut, bench)
    want = sc.free_beam_codes(start_deg, rpm, fs, np.arange(steps))
    assert np.array_equal(np.array(got), want)
    passes_north = bool(np.any(np.abs(np.diff(want)) > 30_000))
    assert len(set(got)) > 400 and passes_north == (start_deg != 90.0)


def acp_events(rng, revolutions, n, *, miss=(), glitch_free=True):
    """ACP and ARP clocks of a radar of ``n`` ACPs a revolution: ACPs at
    least ACP_MIN_CLOCKS apart, with jitter; the ARP with the revolution's
    first ACP or between two ACPs; ``miss``: revolutions whose ARP is lost."""
    clock, acp, arp = 10, [], []
    for rev in range(revolutions):
        for k in range(n):
            clock += ACP_MIN_CLOCKS + rng.randrange(0, 6)
            if k == 0 and rev not in miss:
                arp.append(clock if rng.random() < 0.5 else clock - rng.randrange(1, ACP_MIN_CLOCKS - 2))
            acp.append(clock)
    return acp, arp, clock + 50


def run_acp(dut, acp, arp, end, *, mode_auto, log2=12, restart_at=None):
    """Drive the strobes; return each clock's (beam, arp_lost, per_rev)."""
    acp, arp = set(acp), set(arp)
    seen = []

    async def bench(ctx):
        settings(dut, ctx, "acp", auto=int(mode_auto), acp_log2=log2)
        for clock in range(end):
            ctx.set(dut.acp, clock in acp)
            ctx.set(dut.arp, clock in arp)
            ctx.set(dut.restart, clock == restart_at)
            seen.append((ctx.get(dut.beam), ctx.get(dut.arp_lost), ctx.get(dut.per_rev)))
            await ctx.tick()

    simulate(dut, bench)
    return seen


def track_clocks(track, acp, arp, end):
    """The contract's AcpTrack clock by clock: a clock's outputs show every
    event of the clocks before it."""
    acp, arp = set(acp), set(arp)
    out = []
    for clock in range(end):
        out.append((track.code, int(track.lost), track.n))
        if clock in acp or clock in arp:
            track.event(clock in arp, clock in acp)
    return out


@pytest.mark.parametrize("n", [4096, 512])
def test_fixed_acp_count_and_a_missing_arp(n):
    """acp_per_rev fixed (2**12 and, for a short run, 2**9): the code after
    each ACP, ARP-lost raised by the ACP past N of a revolution whose ARP is
    missing and cleared by the next ARP, the code going on meanwhile."""
    rng = random.Random(n)
    acp, arp, end = acp_events(rng, 3 if n == 512 else 2, n, miss=(1,))
    got = run_acp(ScanGenerator(), acp, arp, end, mode_auto=False, log2=n.bit_length() - 1)
    want = track_clocks(sc.AcpTrack(n), acp, arp, end)
    assert got == want
    # lost from the ACP past N of the revolution without its ARP; cleared by the next
    # ARP when there is one (the 512-ACP run's third revolution), else still up at the end
    assert any(lost for _, lost, _ in got) and got[-1][1] == int(n == 4096)


def test_learned_acp_count():
    """"auto": 65536 per revolution until an ARP ends a revolution of at
    least 256 ACPs with no ARP missed; then N is that count (here 1000, not a
    power of two), and the code is floor(k·2**16/1000); a restart forgets it."""
    rng = random.Random(7)
    acp, arp, end = acp_events(rng, 4, 1000, miss=(2,))
    restart = acp[-300] + 3
    got = run_acp(ScanGenerator(), acp, arp, end, mode_auto=True, restart_at=restart)
    track = sc.AcpTrack("auto")
    want = track_clocks(track, [a for a in acp if a < restart], [a for a in arp if a < restart], restart + 1)
    track.restart()
    want += track_clocks(track, [a for a in acp if a > restart], [a for a in arp if a > restart], end)[restart + 1:]
    assert got == want
    assert {per for _, _, per in got} == {65536, 1000}


def test_stare_beam_is_zero():
    dut = ScanGenerator()

    async def bench(ctx):
        settings(dut, ctx, "stare", period=1 << 16, start=1234)
        ctx.set(dut.restart, 1)
        await ctx.tick()
        ctx.set(dut.restart, 0)
        for _ in range(50):
            ctx.set(dut.accept, 1)
            ctx.set(dut.acp, 1)
            assert ctx.get(dut.beam) == 0
            await ctx.tick()

    simulate(dut, bench)


# ------------------------------------------------------------------ the pattern gain


@pytest.mark.parametrize("beamwidth, sidelobe", [(1.4, -50.0), (12.0, -40.0), (60.0, -30.0), (100.0, -30.0)])
def test_pattern_gain_is_the_contracts(beamwidth, sidelobe):
    """Random gains, azimuths and beams, the scan on and off: the output
    ``latency`` clocks later is scanned_gain(gain, pattern_lookup(beam − az))."""
    table = sc.pattern_words(AntennaScan("free", 10.0, 0.0, 4096, beamwidth, sidelobe))
    dut = PatternGain()
    rng = random.Random(int(beamwidth * 10))
    inputs, outputs = [], []

    async def bench(ctx):
        for k, w in enumerate(table.words):
            ctx.set(dut.w_en, 1)
            ctx.set(dut.w_addr, k)
            ctx.set(dut.w_data, int(w))
            await ctx.tick()
        ctx.set(dut.w_en, 0)
        ctx.set(dut.shift, table.shift)
        ctx.set(dut.floor, table.floor)
        for clock in range(3000):
            beam = rng.randrange(1 << 16)
            near = (beam + rng.randrange(-2048, 2048)) % (1 << 16)
            v = (rng.randrange(1 << 17), near if rng.random() < 0.8 else rng.randrange(1 << 16), beam,
                 int(rng.random() < 0.9))
            for name, value in zip(("gain", "azimuth", "beam", "scan"), v):
                ctx.set(getattr(dut, name), value)
            inputs.append(v)
            outputs.append(ctx.get(dut.o))
            await ctx.tick()

    simulate(dut, bench)
    g, az, beam, on = (np.array(x, dtype=np.int64) for x in zip(*inputs))
    want = np.where(on == 1, sc.scanned_gain(g, sc.pattern_lookup(table, beam - az)), g)
    got = np.array(outputs[dut.latency:], dtype=np.int64)
    assert np.array_equal(got, want[:len(got)])
    assert len(set(got.tolist())) > 1000


def test_pattern_gain_names_a_bad_site():
    with pytest.raises(ValueError, match="Pattern table site must be a bel name or None, not 3"):
        PatternGain(site=3)
