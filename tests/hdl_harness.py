"""Amaranth-simulator drivers shared by the tests/test_hdl_*.py files.

``run_replay`` drives a :class:`WindFarmReplay` cycle by cycle: input samples
under a valid pattern, output back-pressure under a ready pattern, and register
accesses, recording for every access the step index at which it took effect
(the number of input transfers before the clock it lands in). The
same sequence is then replayed through the bit-exact model.
"""

import itertools

import numpy as np
from amaranth.sim import Simulator

from rast.model.contract.fixedpoint import WRITE_STAGING, take_interval
from rast.sim.scan_drive import pin_levels, pulse_events, merge, model_replay  # noqa: F401 (the tests' model run)


def run_replay(dut, xi, xq, ops=(), valid=(1,), ready=(1,), max_cycles=None, hold=False, pulses=()):
    """Drive ``dut``; ``ops`` is a list of ``(at_step, "w"|"r", addr, value)``.

    ``pulses`` (a block built with the antenna scan): ``(pin, clock, high)``,
    ``pin`` "acp" or "arp" high from ``clock`` for ``high`` clocks. Each one
    the block's filter passes (``high`` at least its filter's clocks; the
    pulses of a pin are taken to be that far apart) is returned among the
    done ops as ``(k, "e", arp, acp)``, k the inputs accepted before the
    clock ``dut.acp_lead`` after its rise (an ARP and an ACP rising together:
    one entry), placed before the accesses of the same k.

    ``valid`` and ``ready`` are patterns repeated clock by clock; an input
    offered stays offered until it is taken (a stream's rule), so the
    pattern's gaps fall between inputs whatever the engine's phase.

    An op is presented from the first cycle in which at least ``at_step``
    inputs have been accepted and taken in the first cycle with ``bus.ready``
    (with ``hold``, no input is offered while an op is due or on its way to
    landing, so the op takes effect exactly at ``at_step``). Returns (yi, yq,
    done_ops) with done_ops a list of ``(k, kind, addr, value_or_readback)``
    in issue order, ``k`` the
    inputs accepted before the op's landing clock, WRITE_STAGING clocks after
    the one it was taken in (the step from which it takes effect).
    """
    xi = [int(v) for v in xi]
    xq = [int(v) for v in xq]
    T = len(xi)
    ops = sorted(ops, key=lambda o: o[0])
    out_i, out_q, done = [], [], []
    M = dut.contract.slots
    limit = max_cycles or ((T + len(ops)) * take_interval(M) * 8 + 400)

    high = pin_levels(pulses)
    accepted_at = []               # the clock of each input taken

    async def bench(ctx):
        vpat = itertools.cycle(valid)
        offered = False            # an input offered and not yet taken stays offered (a stream's rule)
        rpat = itertools.cycle(ready)
        n_in = 0
        op_i = 0
        reads = []                 # indices into done of reads awaiting r_valid
        landing = []               # (landing clock, index into done) of ops not yet landed
        for cycle in range(limit):
            if n_in >= T and len(out_i) >= T and op_i >= len(ops) and not reads and not landing:
                return
            due = op_i < len(ops) and ops[op_i][0] <= n_in
            v = 1 if offered else (next(vpat) if n_in < T else 0)
            if hold and (due or landing):
                v = 0
            r = next(rpat)
            ctx.set(dut.i.valid, v)
            if n_in < T:
                ctx.set(dut.i.payload.re, xi[n_in])
                ctx.set(dut.i.payload.im, xq[n_in])
            ctx.set(dut.o.ready, r)
            if pulses:
                ctx.set(dut.acp, "acp" in high.get(cycle, ()))
                ctx.set(dut.arp, "arp" in high.get(cycle, ()))
            if due:
                op = ops[op_i]
                ctx.set(dut.bus.addr, op[2])
                ctx.set(dut.bus.w_stb, op[1] == "w")
                ctx.set(dut.bus.w_data, op[3] if op[1] == "w" else 0)
                ctx.set(dut.bus.r_stb, op[1] == "r")
            else:
                ctx.set(dut.bus.w_stb, 0)
                ctx.set(dut.bus.r_stb, 0)
            ce = v and ctx.get(dut.i.ready)
            offered = bool(v and not ce)
            taken = due and ctx.get(dut.bus.ready)
            if ctx.get(dut.o.valid) and r:
                out_i.append(ctx.get(dut.o.payload.re))
                out_q.append(ctx.get(dut.o.payload.im))
            if ctx.get(dut.bus.r_valid):
                done[reads.pop(0)][3] = ctx.get(dut.bus.r_data)
            while landing and landing[0][0] == cycle:
                done[landing.pop(0)[1]][0] = n_in
            await ctx.tick()
            if taken:
                op = ops[op_i]
                op_i += 1
                landing.append((cycle + WRITE_STAGING, len(done)))
                if op[1] == "r":
                    reads.append(len(done))
                    done.append([None, "r", op[2], None])
                else:
                    done.append([None, "w", op[2], op[3]])
            if ce:
                n_in += 1
                accepted_at.append(cycle)
        raise AssertionError(f"run_replay: not finished after {limit} cycles "
                             f"({n_in}/{T} in, {len(out_i)} out, {op_i}/{len(ops)} ops)")

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    done = [tuple(d) for d in done]
    if pulses:
        done = merge(done, pulse_events(pulses, accepted_at, dut.acp_lead, dut.acp_filter_clocks))
    return (np.array(out_i, dtype=np.int64), np.array(out_q, dtype=np.int64), done)


def assert_same(name, xi, xq, hi, hq, mi, mq):
    """Integer comparison; on failure report the first differing step with context."""
    assert len(hi) == len(mi), f"{name}: gateware gave {len(hi)} samples, model {len(mi)}"
    bad = np.nonzero((hi != mi) | (hq != mq))[0]
    if len(bad):
        n = int(bad[0])
        raise AssertionError(
            f"{name}: first mismatch at output step {n} of {len(hi)} ({len(bad)} steps differ): "
            f"gateware ({hi[n]}, {hq[n]}), model ({mi[n]}, {mq[n]}); input at that step "
            f"({xi[n]}, {xq[n]}); gateware[{max(0, n-3)}:{n+4}] I={hi[max(0, n-3):n+4].tolist()}, "
            f"model I={mi[max(0, n-3):n+4].tolist()}")


def assert_reads(name, reads):
    for k, addr, expect, got in reads:
        assert expect == got, (f"{name}: read of register {addr:#x} at step {k}: gateware {got:#x}, "
                               f"model {expect:#x}")
