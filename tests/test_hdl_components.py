"""Complex multiplier, delay line and one channel's stream against the bit-exact model's functions."""

import itertools
import warnings
from fractions import Fraction

import numpy as np
import pytest
from amaranth.sim import Simulator

from rast.hdl.cmult import ComplexMultiplier
from rast.hdl.delay_line import DelayLine
from rast.hdl.stream_pool import StreamPool
from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.powerup import ChannelInit
from rast.hdl.iq import IQ
from rast.model.contract import datapath as dp
from rast.model.contract.fixedpoint import (pack_iq, unpack_iq, PHASE_FRAC_BITS, POOL_BANK_WORDS,
                                            STREAM_WIDTH, ReplayContract)

ONE = 1 << PHASE_FRAC_BITS


def simulate(dut, bench):
    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


# ---------------------------------------------------------------- parameters

@pytest.mark.parametrize("args, exc, msg", [
    (dict(a_width=0), TypeError, r"^Operand A width must be a positive integer, not 0$"),
    (dict(shift=0), ValueError, r"^Rounding shift must be an integer in \[1, 31\], not 0$"),
    (dict(shift=32), ValueError, r"^Rounding shift must be an integer in \[1, 31\], not 32$"),
    (dict(form="5mult"), ValueError,
     r"^Complex multiplier form must be one of 4mult, 3mult, not '5mult'$"),
    (dict(operand_registers=1), TypeError, r"^Operand registers must be a bool, not 1$"),
    (dict(second_b="yes"), TypeError, r"^Second B operand must be a bool, not 'yes'$"),
])
def test_cmult_parameters(args, exc, msg):
    with pytest.raises(exc, match=msg):
        ComplexMultiplier(**args)


def test_delay_line_parameters():
    with pytest.raises(TypeError, match=r"^Delay line width must be a positive integer, not 0$"):
        DelayLine(0, 4)
    with pytest.raises(TypeError, match=r"^Maximum delay must be a non-negative integer, not -1$"):
        DelayLine(8, -1)
    with pytest.raises(ValueError, match=r"^Lag must be a positive integer, not 0$"):
        DelayLine(8, 4, lag=0)
    with pytest.raises(ValueError, match="Group bits"):
        DelayLine(8, 4, group_bits=9)
    with pytest.raises(ValueError, match=r"^Sites must be None or, with groups of block RAMs, 4 bel names, "):
        DelayLine(8, 8190, group_bits=2, sites=["X4/Y22/EBR0"])
    with pytest.raises(ValueError, match=r"^Sites must be None or, with groups of block RAMs, no bel names, "):
        DelayLine(8, 4, sites=["X4/Y22/EBR0"])
    with pytest.raises(ValueError, match="Address copies must be None without groups"):
        DelayLine(8, 4, address_copies=1)
    with pytest.raises(ValueError, match=r"Address copies .* an integer in \[1, 4\], not 5"):
        DelayLine(8, 4, group_bits=2, address_copies=5)
    with pytest.raises(ValueError, match=r"^Reserved sites must be a non-negative integer, not -1$"):
        StreamPool(16, 4, reserve_sites=-1)
    with pytest.raises(ValueError, match=r"^Block sites must be a non-negative integer, not True$"):
        StreamPool(16, 4, block_sites=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # never elaborated: UnusedElaboratable
        assert [DelayLine(8, d).depth for d in (0, 14, 15)] == [2, 16, 32]
        assert DelayLine(8, 14, lag=2).depth == 32


def test_stream_pool_parameters():
    with pytest.raises(ValueError, match=r"^Pool words must be a power of two from 16 to 16384 or a "
                                         r"multiple of 16384, not 48$"):
        StreamPool(48, 4)


@pytest.mark.parametrize("words", [64, 3 * POOL_BANK_WORDS])
def test_stream_pool_reads_and_writes(words):
    """Random reads and writes (some of the address written in the same clock,
    many in the last words of one bank and the first of the next) against a
    dictionary: each fetch's word and tag come back ``latency`` clocks later,
    a write is visible to a read presented with it, an address beyond the
    pool reads 0 and is not written, and ``d_valid`` is high only for fetches."""
    init = [(k * 0x9E3779B9) & 0xFFFFFFFF for k in range(37)]
    dut = StreamPool(words, 5, init=init)
    aw = len(dut.r_addr)
    mem = dict(enumerate(init))
    rng = np.random.default_rng(words)
    hot = [a % (1 << aw) for b in range(1, words // POOL_BANK_WORDS + 1)
           for a in range(b * POOL_BANK_WORDS - 3, b * POOL_BANK_WORDS + 3)] or list(range(words))
    expected, got = [], []

    def addr():
        return int(rng.choice(hot)) if rng.random() < 0.5 else int(rng.integers(0, 1 << aw))

    async def bench(ctx):
        for cycle in range(1500 + dut.latency):
            if cycle < 1500:
                we, re_ = rng.random() < 0.4, rng.random() < 0.6
                wa, wd, ra, tag = addr(), int(rng.integers(0, 1 << 32)), addr(), int(rng.integers(0, 32))
                if rng.random() < 0.15:
                    ra = wa
                ctx.set(dut.w_en, we); ctx.set(dut.w_addr, wa); ctx.set(dut.w_data, wd)
                ctx.set(dut.r_valid, re_); ctx.set(dut.r_addr, ra); ctx.set(dut.r_tag, tag)
                if we and wa < words:
                    mem[wa] = wd
                if re_:
                    expected.append((cycle + dut.latency, tag, mem.get(ra, 0) if ra < words else 0))
            else:
                ctx.set(dut.w_en, 0); ctx.set(dut.r_valid, 0)
            if ctx.get(dut.d_valid):
                got.append((cycle, ctx.get(dut.d_tag), ctx.get(dut.d_data)))
            await ctx.tick()

    simulate(dut, bench)
    assert len(expected) > 800
    assert got == expected


@pytest.mark.parametrize("depth", [2, 7, 16])
def test_output_fifo_keeps_order_and_flags_an_overrun(depth):
    """The output FIFO against a queue: random writes (only with room, as the
    credit counter ensures) and random reads, every word out in order, r_rdy
    exactly when the queue holds a word, no overrun; then a write into the
    full FIFO sets ``overrun``."""
    from collections import deque
    from rast.hdl.output_fifo import OutputFIFO
    with pytest.raises(TypeError, match=r"^Output FIFO depth must be an integer of at least 2, not 1$"):
        OutputFIFO(8, 1)
    dut = OutputFIFO(32, depth)
    rng = np.random.default_rng(depth)
    queue, written, read = deque(), [], []

    async def bench(ctx):
        for _ in range(2000):
            r_en = bool(rng.random() < 0.5)
            assert ctx.get(dut.r_rdy) == bool(queue)
            taken = r_en and bool(queue)
            if taken:
                assert ctx.get(dut.r_data) == queue.popleft()
                read.append(1)
            w_en = bool(rng.random() < 0.55) and len(queue) < depth
            word = int(rng.integers(0, 1 << 32))
            if w_en:
                queue.append(word)
                written.append(word)
            ctx.set(dut.r_en, r_en); ctx.set(dut.w_en, w_en); ctx.set(dut.w_data, word)
            await ctx.tick()
        assert not ctx.get(dut.overrun)
        ctx.set(dut.r_en, 0); ctx.set(dut.w_en, 1)
        for _ in range(depth - len(queue)):          # fill it
            await ctx.tick()
        assert not ctx.get(dut.overrun)
        await ctx.tick()
        assert ctx.get(dut.overrun)

    simulate(dut, bench)
    assert len(written) > 800 and len(read) > 700


def test_stream_pool_ecp5_register_trees():
    """A pool of several banks on ECP5: each group of GROUP_BITS slices has a
    read address, a write enable, address and data, and the read's bank hit
    (which clears its data register) of its own in kept flip-flops (so
    synthesis cannot merge the copies back into one register that drives
    every block RAM), behind a kept register per bank of the write's address
    and data."""
    from amaranth.back import rtlil
    banks = 5
    text = rtlil.convert(StreamPool(banks * POOL_BANK_WORDS, 4), platform=type("ECP5", (), {"family": "ecp5"})())
    slices = 2 * STREAM_WIDTH                # one bit per DP16KD (16384 x 1)
    groups = banks * slices // StreamPool.GROUP_BITS
    address_bits = (POOL_BANK_WORDS - 1).bit_length()
    assert text.count("cell \\DP16KD") == banks * slices
    assert text.count("cell \\TRELLIS_FF") == (groups * (2 * address_bits + StreamPool.GROUP_BITS + 1 + 1)
                                               + banks * (address_bits + slices))
    assert "attribute \\BEL" not in text   # no device named: no floorplan


def _dp16kd_bels(top):
    """``{instance path: BEL}`` of the DP16KD instances of ``top`` elaborated
    for the LFE5U-85F: the ``BEL`` attributes its netlist carries, read from
    the elaborated hierarchy (a fifth of the time of writing the RTLIL)."""
    from amaranth.hdl import Fragment, Instance
    bels = {}

    def walk(fragment, path):
        for k, (sub, name, _) in enumerate(fragment.subfragments):
            sub_path = f"{path}.{name if name is not None else f'U${k}'}"
            if isinstance(sub, Instance):
                if sub.type == "DP16KD":
                    bels[sub_path] = sub.attrs.get("BEL")
            else:
                walk(sub, sub_path)
    walk(Fragment.get(top, _85F()), "top")
    return bels


_85F = type("ECP5", (), {"family": "ecp5", "device": "LFE5U-85F"})


@pytest.mark.parametrize("banks", [2, 5, 6])
def test_stream_pool_floorplan_on_the_85f(banks):
    """On an LFE5U-85F the banks' groups are placed: the groups of bits
    8k..8k+7 of every bank in block-RAM row k in bank order, each group in
    neighbouring sites, the sites left for other RAMs spread between them,
    every slice at a site of its own."""
    import re
    from rast.hdl.ecp5_primitives import block_ram_rows
    rows = block_ram_rows(_85F())
    assert [len(r) for r in rows] == [52] * 4 and len({s for r in rows for s in r}) == 208
    bels = _dp16kd_bels(StreamPool(banks * POOL_BANK_WORDS, 4))
    assert len(bels) == banks * 2 * STREAM_WIDTH and None not in bels.values()
    assert len(set(bels.values())) == len(bels)
    G = StreamPool.GROUP_BITS
    groups = {}
    for path, bel in bels.items():
        b, g = map(int, re.search(r"bank(\d+)_bits(\d+)", path).groups())
        groups.setdefault((b, g), []).append(bel)
    assert len(groups) == banks * 2 * STREAM_WIDTH // G
    free = 52 - banks * G
    for g in range(0, 2 * STREAM_WIDTH, G):
        row = rows[g // G]
        starts = []
        for b in range(banks):
            index = sorted(row.index(bel) for bel in groups[b, g])   # every bel in row g // G
            assert index == list(range(index[0], index[0] + G))      # neighbouring sites
            starts.append(index[0])
        # in bank order, the free sites spread: no gap before, between or
        # after the groups more than one site longer than another
        ends = [0] + [s + G for s in starts]
        gaps = [s - e for s, e in zip(starts + [52], ends)]
        assert min(gaps) >= 0 and sum(gaps) == free and max(gaps) - min(gaps) <= 1


def test_the_common_line_lies_in_a_block_the_pool_keeps_free():
    """With the pool's banks placed, its floorplan keeps a block of sites in
    the middle of each row for the common delay line: its 16 block RAMs in 4
    neighbouring sites of every row, none shared with the pool, whose groups
    still lie in neighbouring sites in bank order."""
    from rast.hdl.ecp5_primitives import block_ram_rows
    from rast.hdl.replay_top import WindFarmReplay
    rows = block_ram_rows(_85F())
    bels = _dp16kd_bels(WindFarmReplay(10, slots=10, pool_words=5 * POOL_BANK_WORDS, max_delay=8190, max_tap=2046))
    common = [bel for path, bel in bels.items() if ".common." in path or path.startswith("common")]
    pool = {bel for path, bel in bels.items() if "bank" in path}
    assert len(common) == 16 and len(pool) == 160 and not set(common) & pool
    for row in rows:
        index = sorted(row.index(bel) for bel in common if bel in row)
        assert len(index) == 4 and index == list(range(index[0], index[0] + 4))
        assert 52 // 4 <= index[0] <= 3 * 52 // 4                      # in the row's middle half
        banks = sorted(row.index(bel) for bel in pool if bel in row)
        assert len(banks) == 40


@pytest.mark.slow
@pytest.mark.parametrize("channels, slots, banks, per_row", [(64, 10, 5, [2, 2, 2, 1]), (16, 2, 4, [2, 2, 2, 2])])
def test_each_window_lies_in_a_block_of_its_own(channels, slots, banks, per_row):
    """With the pool's banks placed, the sites it leaves are blocks of
    neighbouring sites, one for each pipeline's window, taken from the rows
    in turn: at 64 channels (seven pipelines) and 16 channels at M = 2
    (eight) every window's 4 block RAMs in 4 neighbouring sites of one row,
    the windows spread over the four rows, two windows of one row in
    different halves of it, no site shared with the pool, the common line
    or another window."""
    import re
    from rast.hdl.ecp5_primitives import block_ram_rows
    from rast.hdl.replay_top import WindFarmReplay
    rows = block_ram_rows(_85F())
    P = -(-channels // slots)
    bels = _dp16kd_bels(WindFarmReplay(channels, slots=slots, pool_words=banks * POOL_BANK_WORDS,
                                       max_delay=8190, max_tap=2046))
    assert len(bels) == banks * 32 + 16 + P * 4 and None not in bels.values()
    assert len(set(bels.values())) == len(bels)
    windows = {}
    for path, bel in bels.items():
        if "window" in path:
            windows.setdefault(int(re.search(r"pipe(\d+)", path).group(1)), []).append(bel)
    assert sorted(windows) == list(range(P))
    starts = {r: [] for r in range(4)}
    for p, sites in windows.items():
        (row,) = {k for k, r in enumerate(rows) for bel in sites if bel in r}
        index = sorted(rows[row].index(bel) for bel in sites)
        assert index == list(range(index[0], index[0] + 4)), (p, index)
        starts[row].append(index[0])
    assert [len(starts[r]) for r in range(4)] == per_row
    for r, s in starts.items():
        if len(s) == 2:
            assert min(s) < 26 <= max(s), (r, s)


@pytest.mark.slow
@pytest.mark.parametrize("channels, slots", [(64, 10), (32, 10), (16, 2)])
def test_an_sdram_build_places_its_delay_lines(channels, slots):
    """With the streams in SDRAM (no pool banks to place), the delay lines
    are still placed: the common line's 16 block RAMs in 4 neighbouring
    sites in the middle of each row, each window's 4 in neighbouring sites
    of one row, the windows taken from the rows in turn, in a checkerboard
    of the rows' halves (no half of a row with two windows while another
    half of that row has none), no site used twice."""
    import re
    from rast.hdl.ecp5_primitives import block_ram_rows
    rows = block_ram_rows(_85F())
    P = -(-channels // slots)
    bels = _dp16kd_bels(WindFarmReplay(channels, slots=slots, pool="sdram", pool_words=1 << 20,
                                       max_delay=8190, max_tap=2046))
    assert len(bels) == 16 + P * 4 and None not in bels.values()
    assert len(set(bels.values())) == len(bels)
    common = [bel for path, bel in bels.items() if "window" not in path]
    for row in rows:
        index = sorted(row.index(bel) for bel in common if bel in row)
        assert len(index) == 4 and index == list(range(index[0], index[0] + 4))
        assert 52 // 4 <= index[0] <= 3 * 52 // 4
    windows = {}
    for path, bel in bels.items():
        if "window" in path:
            windows.setdefault(int(re.search(r"pipe(\d+)", path).group(1)), []).append(bel)
    assert sorted(windows) == list(range(P))
    used = {}
    for p, sites in windows.items():
        (row,) = {k for k, r in enumerate(rows) for bel in sites if bel in r}
        index = sorted(rows[row].index(bel) for bel in sites)
        assert index == list(range(index[0], index[0] + 4)), (p, index)
        assert row == p % 4                                            # the rows in turn
        used.setdefault((row, index[0] >= 26), []).append(p)
    for row in range(4):
        left, right = len(used.get((row, False), [])), len(used.get((row, True), []))
        assert abs(left - right) <= 1, (row, left, right)
    if P >= 4:                                                         # rows 0 and 1 start in different halves
        assert (0, False) in used and (1, True) in used or (0, True) in used and (1, False) in used


@pytest.mark.slow
@pytest.mark.parametrize("pool", ["bram", "sdram"])
def test_each_pattern_table_lies_beside_its_pipelines_window(pool):
    """With the antenna scan, each pipeline's pattern table has the site
    right after its window's four, in the same row (its block holds five),
    for the default build's pool and for an SDRAM build; no site used
    twice."""
    import re
    from rast.hdl.ecp5_primitives import block_ram_rows
    rows = block_ram_rows(_85F())
    words = 65536 if pool == "bram" else 1 << 20
    bels = _dp16kd_bels(WindFarmReplay(64, slots=8, pool=pool, pool_words=words, max_delay=8190,
                                       max_tap=2046, scan=True))
    assert None not in bels.values() and len(set(bels.values())) == len(bels)
    windows, tables = {}, {}
    for path, bel in bels.items():
        p = re.search(r"pipe(\d+)", path)
        if p and "window" in path:
            windows.setdefault(int(p.group(1)), []).append(bel)
        elif p and "pattern_gain" in path:
            tables[int(p.group(1))] = bel
    assert sorted(windows) == sorted(tables) == list(range(8))
    for p in range(8):
        (row,) = [r for r in rows if tables[p] in r]
        index = sorted(row.index(bel) for bel in windows[p])
        assert index == list(range(index[0], index[0] + 4)) and row.index(tables[p]) == index[0] + 4, p


def test_stream_pool_no_floorplan_where_rows_lack_room():
    """Seven banks do not fit a row of 52 sites with a group each: no floorplan."""
    from amaranth.back import rtlil
    text = rtlil.convert(StreamPool(7 * POOL_BANK_WORDS, 4), platform=_85F())
    assert "attribute \\BEL" not in text and text.count("cell \\DP16KD") == 7 * 2 * STREAM_WIDTH


@pytest.mark.parametrize("args, exc, msg", [
    (dict(channels=0), ValueError, r"^Channel count must be a positive integer, not 0$"),
    (dict(channels=513), ValueError, r"^Channel count must be at most 512, not 513$"),
    (dict(slots=0), ValueError, r"^Slots per pipeline must be a positive integer, not 0$"),
    (dict(slots=65), ValueError, r"^Slots per pipeline must be at most 64, not 65$"),
    (dict(channels=2.0), TypeError, r"^Channel count must be a positive integer, not 2.0$"),
    (dict(pool_words=100), ValueError,
     r"^Pool words must be a power of two from 16 to 16384 or a multiple of 16384, not 100$"),
    (dict(pool_words=8), ValueError, r"^Pool words must be an integer of at least 16, not 8$"),
    (dict(pool_words=20000), ValueError,
     r"^Pool words must be a power of two from 16 to 16384 or a multiple of 16384, not 20000$"),
    (dict(max_delay=-1), ValueError, r"^Maximum delay must be a positive integer, not -1$"),
    (dict(max_tap=0), ValueError, r"^Maximum tap must be a positive integer, not 0$"),
    (dict(cmult_form="x"), ValueError,
     r"^Complex multiplier form must be one of 4mult, 3mult, not 'x'$"),
])
def test_contract_parameters(args, exc, msg):
    with pytest.raises(exc, match=msg):
        ReplayContract(**args)


def test_iq_layout():
    assert IQ(16).size == 32
    with pytest.raises(TypeError, match=r"^I/Q width must be a positive integer, not 0$"):
        IQ(0)


# ---------------------------------------------------------------- cmult

@pytest.mark.parametrize("operand_registers, second_b", [(False, False), (True, False), (True, True)])
@pytest.mark.parametrize("form", ["4mult", "3mult"])
def test_cmult_random_and_extremes(form, operand_registers, second_b):
    rng = np.random.default_rng(3)
    ext = [-32768, -32767, -1, 0, 1, 32767]
    corner = np.array(list(itertools.product(ext, repeat=4)), dtype=np.int64)
    rand = rng.integers(-32768, 32768, size=(300, 4))
    ops = np.concatenate([corner, rand])
    dut = ComplexMultiplier(form=form, operand_registers=operand_registers, second_b=second_b)
    assert dut.o_width == 18
    lat = dut.latency
    got = []
    en_pat = itertools.cycle([1, 1, 0, 1, 0, 0, 1])

    async def bench(ctx):
        n = 0
        while len(got) < len(ops):
            en = next(en_pat)
            ar, ai, br, bi = (int(v) for v in ops[min(n, len(ops) - 1)])
            ctx.set(dut.a.re, ar); ctx.set(dut.a.im, ai)
            ctx.set(dut.b.re, br); ctx.set(dut.b.im, bi)
            if second_b:
                ctx.set(dut.b2.re, br); ctx.set(dut.b2.im, bi)
            ctx.set(dut.en, en)
            if en:
                if n >= lat:
                    got.append((ctx.get(dut.o.re), ctx.get(dut.o.im)))
                n += 1
            await ctx.tick()

    simulate(dut, bench)
    got = np.array(got)
    ei, eq = dp.cmult(ops[:, 0], ops[:, 1], ops[:, 2], ops[:, 3])
    for k in range(len(ops)):
        assert (got[k, 0], got[k, 1]) == (ei[k], eq[k]), \
            f"{form}: a=({ops[k,0]},{ops[k,1]}) b=({ops[k,2]},{ops[k,3]}) step {k}: gateware " \
            f"{tuple(got[k])}, model ({ei[k]}, {eq[k]})"



@pytest.mark.parametrize("shift", [1, 2, 4, 8])
@pytest.mark.parametrize("form", ["4mult", "3mult"])
def test_cmult_narrow_rounding_every_shift(form, shift):
    """Small widths and shifts from 1 to the largest (8: the most positive
    sum, 2**8, rounds to 1; the rounding constant folded into the low and
    high sums' bits has an edge at every shift): o is
    floor((a*b + 2**(shift-1)) / 2**shift) for each part, every product of
    ±5-bit and 4-bit parts' extremes and random values."""
    rng = np.random.default_rng(shift)
    ext_a, ext_b = [-16, -15, -1, 0, 1, 15], [-8, -7, -1, 0, 1, 7]
    corner = np.array([(p, q, r, t) for p, q in itertools.product(ext_a, repeat=2)
                       for r, t in itertools.product(ext_b, repeat=2)], dtype=np.int64)
    rand = np.concatenate([rng.integers(-16, 16, size=(200, 2)), rng.integers(-8, 8, size=(200, 2))], axis=1)
    ops = np.concatenate([corner, rand])
    dut = ComplexMultiplier(5, 4, shift, form)
    got = []

    async def bench(ctx):
        for n in range(len(ops) + dut.latency):
            ar, ai, br, bi = (int(v) for v in ops[min(n, len(ops) - 1)])
            ctx.set(dut.a.re, ar); ctx.set(dut.a.im, ai)
            ctx.set(dut.b.re, br); ctx.set(dut.b.im, bi)
            ctx.set(dut.en, 1)
            if n >= dut.latency:
                got.append((ctx.get(dut.o.re), ctx.get(dut.o.im)))
            await ctx.tick()

    simulate(dut, bench)
    ar, ai, br, bi = ops.T
    half = 1 << (shift - 1)
    want_re = (ar * br - ai * bi + half) >> shift
    want_im = (ar * bi + ai * br + half) >> shift
    assert got == list(zip(want_re.tolist(), want_im.tolist()))

# ---------------------------------------------------------------- delay line

@pytest.mark.parametrize("lag, group_bits, copies", [(1, None, None), (2, None, None), (1, 5, None),
                                                     (2, 16, None), (1, 2, 4), (2, 5, 1)])
def test_delay_line_every_delay_with_gaps(lag, group_bits, copies):
    """One word per step (written at its step index), read for each step at a
    delay that changes: out = x[n - lag - d], checked directly and against the
    model's ``delay_line``. With groups of block RAMs (registers of their
    own) the write is presented a clock before the read for its step, as the
    engine's common line did; with a level of read-address copies too, in the
    same clock as the read (``latency`` 4), as it does now."""
    maxd = 13
    dut = DelayLine(16, maxd, lag, group_bits=group_bits, address_copies=copies)
    assert dut.latency == (3 if copies is None else 4)
    D = dut.depth
    rng = np.random.default_rng(5)
    per = 40
    delays = np.repeat(np.arange(maxd + 1), per)
    delays = np.concatenate([delays, rng.integers(0, maxd + 1, 200)])  # random changes too
    x = rng.integers(0, 1 << 16, len(delays))
    got = []
    en_pat = itertools.cycle([1, 0, 1, 1, 0])

    async def bench(ctx):
        n = 0
        pending = []                   # steps whose read is in the RAM's pipeline
        held = None                    # with groups: the read of the step written a clock ago
        while n < len(x) or pending or held is not None:
            en = next(en_pat) if n < len(x) else 0
            ctx.set(dut.w_en, en)
            read = n if en else None
            if en:
                ctx.set(dut.w_index, n % D); ctx.set(dut.w_data, int(x[n]))
                n += 1
            else:                      # don't-care values where nothing is written or read
                ctx.set(dut.w_index, int(rng.integers(D))); ctx.set(dut.w_data, int(rng.integers(1 << 16)))
            if group_bits is not None and copies is None:
                read, held = held, read
            if read is not None:       # the read for a step in the clock its write reaches the RAM
                ctx.set(dut.r_index, read % D); ctx.set(dut.r_delay, int(delays[read]))
            else:
                ctx.set(dut.r_index, int(rng.integers(D))); ctx.set(dut.r_delay, int(rng.integers(maxd + 1)))
            pending = [t - 1 for t in pending]
            if pending and pending[0] == 0:
                got.append(ctx.get(dut.o))
                pending.pop(0)
            if read is not None:
                pending.append(dut.latency)
            await ctx.tick()

    simulate(dut, bench)
    expect = dp.delay_line(x, delays, lag)
    got = np.array(got)
    bad = np.nonzero(got != expect)[0]
    assert not len(bad), f"step {bad[0]} delay {delays[bad[0]]}: gateware {got[bad[0]]}, model {expect[bad[0]]}"
    # exactness, independently of the model: with a constant delay d, out[n] = x[n - lag - d]
    for d in range(maxd + 1):
        lo = d * per + lag + maxd + 1
        for n in range(lo, (d + 1) * per):
            assert got[n] == x[n - lag - d], f"delay {d}, step {n}"


# ---------------------------------------------------------------- one channel's stream

def _one_channel(words, length, inc, interpolation, slots, steps, valid=(1,)):
    """One channel playing ``words`` at unit gain, its input a constant 0.5:
    the output sample n is the word at the multiplier halved (rounded)."""
    dut = WindFarmReplay(1, slots=slots, pool_words=16, max_delay=2, max_tap=1,
                         interpolation=interpolation,
                         init=[ChannelInit(tuple(int(w) for w in words[:length]), inc, 1 << 16, 0, True)])
    from hdl_harness import run_replay
    x = np.full(steps, 16384, dtype=np.int64)
    yi, yq, _ = run_replay(dut, x, np.zeros(steps, dtype=np.int64), valid=valid)
    return dut, yi, yq


@pytest.mark.parametrize("interpolation, slots", [("hold", 1), ("linear", 2), ("fir", 1), ("fir", 3)])
def test_stream_wraps_at_length(interpolation, slots):
    """The word played at step n is the stream's word for the phase
    ``(n - R) * PHASE_INC mod LENGTH * 2**32`` (muted for the R refill steps
    after reset), by ``phase_sequence`` and ``stream_words`` alone."""
    rng = np.random.default_rng(7)
    depth, length = 16, 11
    wi, wq = rng.integers(-32768, 32768, depth), rng.integers(-32768, 32768, depth)
    words = pack_iq(wi, wq)
    c = ReplayContract(channels=1, slots=slots, pool_words=depth, interpolation=interpolation)
    # the largest rates it takes, so the index (FIR: J) advances as often as allowed
    inc = int(rng.integers(c.max_phase_increment // 5, c.max_phase_increment + 1))
    R = c.refill_samples
    steps = R + min(length * ONE // inc, 1500) + 300
    dut, yi, yq = _one_channel(words, length, inc, interpolation, slots, steps, valid=(1, 1, 0))
    ph = dp.phase_sequence(0, inc, length, steps - R)
    ei, eq = dp.stream_words(interpolation, words, length, ph)
    # output = cmult(x, w) * 1.0 with x = 0.5 and the window's 2-sample lag: (w + 1) >> 1
    half = lambda v: (np.asarray(v) * 16384 + 16384) >> 15
    assert not yi[:R].any() and not yq[:R].any(), "not muted during the refill after reset"
    wr, wim = half(ei), half(eq)
    # the input is 0 for the first L steps (the delay lines start empty)
    L = dut.latency
    assert (yi[max(R, L):] == wr[max(0, L - R):]).all() and (yq[max(R, L):] == wim[max(0, L - R):]).all()


def test_stream_long_run_exact_period():
    """3 words at 0.3709... words per sample: hundreds of wraps, the word index
    exact at every step."""
    inc = 1593012345
    words = pack_iq([1000, 2000, 3000], [0, 0, 0])
    steps = 5000
    dut, yi, _ = _one_channel(words, 3, inc, "hold", 1, steps)
    R = dut.contract.refill_samples
    ph = dp.phase_sequence(0, inc, 3, steps - R)
    assert (yi[R:] == 500 * ((ph >> 32) + 1)).all()            # words 1000, 2000, 3000 halved


@pytest.mark.parametrize("rate", [Fraction(1, 3), Fraction(4321, 1000000), Fraction(999, 1000)])
def test_rate_accumulator_drift_bound(rate):
    """Model, long run: the phase after n steps differs from the exact rate by at most
    n * 2**-33 words (the increment is rounded to 2**-32 words per sample)."""
    inc = round(rate * ONE)
    length = 1000
    for n in (10**6, 10**9, 10**12):
        ph = int(dp.phase_sequence((n - 1) * inc % (length * ONE), inc, length, 2)[1])
        exact = (rate * n) % length
        err = abs(Fraction(ph, ONE) - exact)
        err = min(err, length - err)
        assert err <= Fraction(n, 2 * ONE), f"rate {rate}, n {n}: error {float(err)} words"
