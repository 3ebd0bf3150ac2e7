"""cocotb testbench of the SDRAM stream pool on LiteDRAM's simulation core.

Run from ``tests/test_sdram_cosim.py``; parameters arrive as JSON in
``RAST_TB_PARAMS``. Three checkers run beside the stimulus and any one fails
the test:

* :class:`DFIChecker`, on the SDRAM clock: every command the controller puts
  on the DFI of LiteDRAM's ``SDRAMPHYModel`` (what the SDRAM pins would carry,
  one register later) against the module's datasheet timings in ns (tRCD, tRP,
  tRAS, tRC, tWR, tRFC, tRRD, auto-precharge's tDAL), bank state (no read or
  write to a closed bank, no ACT to an open one), the mode register (the CAS
  latency and burst length the controller assumes), the init order (precharge
  all, mode register, precharge all, refresh, refresh, mode register, after the
  power-up wait) and the refresh interval (no gap between refreshes longer
  than ``refresh_slack`` × tREFI, and at least ⌊T/tREFI⌋ - 1 refreshes).
* the answer checker: every ``d_valid`` is the oldest taken fetch, its tag
  and word compared as integers with a model memory updated at each taken host
  write (one queue: the word a fetch sees is the one written before it was
  taken); every ``rd_data_valid`` likewise.
* ``lost`` and ``init_error`` stay 0.

``inject`` makes the checkers see a wrong expectation on purpose ("corrupt":
one word's model value, "reorder": two answers swapped, "timing": tRCD
demanded 3 clocks long) so that the tests can show they fail.
"""

from __future__ import annotations

import collections
import json
import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge, SimTimeoutError, Timer, with_timeout
from cocotb.utils import get_sim_time

from rast.sim.testbench import params, run_dir

SYNC_NS = 5       # 200 MHz engine clock
CMDS = {  # (cs_n, ras_n, cas_n, we_n) -> name
    (0, 0, 1, 1): "ACT", (0, 1, 0, 1): "RD", (0, 1, 0, 0): "WR", (0, 0, 1, 0): "PRE",
    (0, 0, 0, 1): "REF", (0, 0, 0, 0): "MRS", (0, 1, 1, 0): "BST",
}
INIT_ORDER = ["PRE*", "MRS", "PRE*", "REF", "REF", "MRS"]
POWER_UP_NS = 100_000


class TestFailure(AssertionError):
    pass


def fail(msg: str):
    (run_dir() / "failure.txt").write_text(msg + "\n")
    raise TestFailure(msg)


class DFIChecker:
    """Datasheet timing and protocol checks of the DFI command stream."""

    def __init__(self, dut, p):
        self.clk = dut.sdram_clk
        core = dut.sdram.litedram
        self.sig = [getattr(core, f"soc_ddrphy_dfi_p0_{n}") for n in ("cs_n", "ras_n", "cas_n", "we_n",
                                                                     "bank", "address")]
        self.tck = p["tck_ns"]
        t = dict(p["timings_ns"])
        for k, f in p.get("timing_scale", {}).items():
            t[k] = t[k] * f
        t["tRC"] = t["tRAS"] + t["tRP"]
        self.t = t
        self.cl = p["cl"]
        self.nbanks = 1 << p["bankbits"]
        self.refresh_slack = p.get("refresh_slack", 2.0)
        self.violations: list[str] = []
        self.log = collections.Counter()
        self.init_seen: list[str] = []
        self.first_cmd_ns = None
        self.refs: list[float] = []
        self.max_ref_gap = 0.0
        self.now = 0.0
        B = self.nbanks
        self.open = [False] * B
        self.act = [-1e18] * B
        self.pre = [-1e18] * B
        self.wr = [-1e18] * B
        self.ap_ready = [-1e18] * B
        self.last_act = -1e18
        self.last_ref = -1e18

    def _v(self, what):
        if len(self.violations) < 50:
            self.violations.append(f"{self.now:.0f} ns: {what}")

    def _gap(self, since, need, rule, bank=None):
        if self.now - since < need - 1e-6:
            b = "" if bank is None else f" bank {bank}"
            self._v(f"{rule} violated{b}: {self.now - since:.1f} ns < {need:.1f} ns")

    def command(self, name, bank, addr):
        t, T = self.now, self.t
        self.log[name] += 1
        if self.first_cmd_ns is None:
            self.first_cmd_ns = t
            if t < POWER_UP_NS:
                self._v(f"first command {name} {t:.0f} ns after start, before the 100 µs power-up wait")
        if len(self.init_seen) < len(INIT_ORDER):
            tag = name + ("*" if name == "PRE" and addr & 0x400 else "")
            self.init_seen.append(tag)
            self.init_end_ns = t
            if tag != INIT_ORDER[len(self.init_seen) - 1]:
                self._v(f"init sequence {self.init_seen} is not {INIT_ORDER}")
        if name == "ACT":
            if self.open[bank]:
                self._v(f"ACT to open bank {bank}")
            self._gap(self.pre[bank], T["tRP"], "tRP", bank)
            self._gap(self.act[bank], T["tRC"], "tRC", bank)
            self._gap(self.last_act, T["tRRD"], "tRRD")
            self._gap(self.last_ref, T["tRFC"], "tRFC")
            if t < self.ap_ready[bank] - 1e-6:
                self._v(f"ACT bank {bank} {self.ap_ready[bank] - t:.1f} ns before its auto precharge ended")
            self.open[bank], self.act[bank], self.last_act = True, t, t
        elif name in ("RD", "WR"):
            if not self.open[bank]:
                self._v(f"{name} to closed bank {bank}")
            self._gap(self.act[bank], T["tRCD"], "tRCD", bank)
            if name == "WR":
                self.wr[bank] = t
            if addr & 0x400:   # auto precharge
                done = t + (T["tWR"] if name == "WR" else self.tck) + T["tRP"]
                self.ap_ready[bank] = max(done, self.act[bank] + T["tRC"])
                self.open[bank] = False
                self.pre[bank] = -1e18
        elif name == "PRE":
            banks = range(self.nbanks) if addr & 0x400 else [bank]
            for b in banks:
                if self.open[b]:
                    self._gap(self.act[b], T["tRAS"], "tRAS", b)
                    self._gap(self.wr[b], T["tWR"], "tWR", b)
                    self.open[b] = False
                    self.pre[b] = t
        elif name == "REF":
            for b in range(self.nbanks):
                if self.open[b]:
                    self._v(f"REF with bank {b} open")
                self._gap(self.pre[b], T["tRP"], "tRP before REF", b)
                if t < self.ap_ready[b] - 1e-6:
                    self._v(f"REF {self.ap_ready[b] - t:.1f} ns before bank {b}'s auto precharge ended")
            self._gap(self.last_ref, T["tRFC"], "tRFC")
            if len(self.init_seen) >= len(INIT_ORDER) and self.refs:
                gap = t - self.refs[-1]
                self.max_ref_gap = max(self.max_ref_gap, gap)
                if gap > self.refresh_slack * T["tREFI"]:
                    self._v(f"refresh gap {gap:.0f} ns > {self.refresh_slack} × tREFI")
            if len(self.init_seen) >= len(INIT_ORDER):
                self.refs.append(t)
            self.last_ref = t
        elif name == "MRS":
            if any(self.open):
                self._v("MRS with a bank open")
            cl, bl = (addr >> 4) & 7, addr & 7
            if cl != self.cl or bl != 0:
                self._v(f"mode register CL={cl} BL code={bl}, the controller assumes CL={self.cl} BL=1")
        elif name == "BST":
            self._v("burst terminate issued")

    async def run(self):
        cs, ras, cas, we, ba, a = self.sig
        n = 0
        while True:
            await FallingEdge(self.clk)
            n += 1
            self.now = n * self.tck
            key = (int(cs.value), int(ras.value), int(cas.value), int(we.value))
            name = CMDS.get(key)
            if name is not None:
                self.command(name, int(ba.value), int(a.value))

    def finish(self):
        """End-of-run checks: refreshes from the init sequence's end to now."""
        start_ns = getattr(self, "init_end_ns", 0.0)
        if self.refs:
            tail = self.now - self.refs[-1]
            self.max_ref_gap = max(self.max_ref_gap, tail)
            if tail > self.refresh_slack * self.t["tREFI"]:
                self._v(f"no refresh for the last {tail:.0f} ns")
            span = self.now - start_ns
            need = int(span // self.t["tREFI"]) - 1
            if len(self.refs) < need:
                self._v(f"{len(self.refs)} refreshes in {span:.0f} ns, fewer than {need}")
        else:
            self._v("no refresh after the init sequence")


class PoolBench:
    def __init__(self, dut, p):
        self.dut, self.p = dut, p
        self.rng = random.Random(p["seed"])
        self.mem: dict[int, int] = {}       # the model: what a read taken now returns
        self.expect = collections.deque()   # (tag, word, cycle taken, address) of taken fetches
        self.host_expect = collections.deque()
        self.cycle = 0
        self.latencies: list[int] = []
        self.stats = collections.Counter()
        self.corrupt_addr = None
        self.reordered = False
        self.answered: list[int] = []       # tags answered, drained by the scan
        self.steady_latencies: list[int] = []   # rate mode: fetches answered once consumption runs

    async def start(self):
        d = self.dut
        Clock(d.clk, SYNC_NS, unit="ns").start()
        Clock(d.sdram_clk, self.p["tck_ns"], unit="ns").start()
        for s in ("r_valid", "w_valid", "rd_valid", "r_addr", "r_tag", "w_addr", "w_data", "rd_addr"):
            getattr(d, s).value = 0
        d.rst.value = 1
        d.sdram_rst.value = 1
        await Timer(100, unit="ns")
        d.rst.value = 0
        d.sdram_rst.value = 0

    def _check_outputs(self):
        d = self.dut
        if int(d.lost.value):
            fail(f"cycle {self.cycle}: lost is set (an answer had no room)")
        if int(d.d_valid.value):
            tag, word = int(d.d_tag.value), int(d.d_data.value)
            if not self.expect:
                fail(f"cycle {self.cycle}: answer tag {tag} word {word:#010x} with no fetch outstanding")
            etag, eword, taken, addr = self.expect.popleft()
            if (tag, word) != (etag, eword):
                fail(f"cycle {self.cycle}: answer tag {tag} word {word:#010x}, expected tag {etag} "
                     f"word {eword:#010x} (address {addr:#x}, fetch taken at cycle {taken})")
            self.latencies.append(self.cycle - taken)
            self.answered.append(tag)
            self.stats["answers"] += 1
        if int(d.rd_data_valid.value):
            word = int(d.rd_data.value)
            if not self.host_expect:
                fail(f"cycle {self.cycle}: host read answer {word:#010x} with no host read outstanding")
            eword, addr = self.host_expect.popleft()
            if word != eword:
                fail(f"cycle {self.cycle}: host read of {addr:#x} returned {word:#010x}, expected {eword:#010x}")
            self.stats["host_reads"] += 1

    async def step(self, drive):
        """One engine clock: ``drive`` sets inputs (a dict), handshakes are
        sampled before the next edge; returns the set of ports that were taken."""
        d = self.dut
        for k, v in drive.items():
            getattr(d, k).value = v
        await ReadOnly()
        taken = set()
        if drive.get("r_valid") and int(d.r_ready.value):
            taken.add("r")
        if drive.get("w_valid") and int(d.w_ready.value):
            taken.add("w")
        if drive.get("rd_valid") and int(d.rd_ready.value):
            taken.add("rd")
        self._check_outputs()
        await RisingEdge(d.clk)
        self.cycle += 1
        return taken

    def model_write(self, addr, word):
        self.mem[addr] = word

    def model_read(self, addr):
        w = self.mem.get(addr)
        if w is None:
            fail(f"testbench reads address {addr:#x}, which it never wrote")
        if addr == self.corrupt_addr:
            w ^= 1
        return w

    def take_fetch(self, tag, addr):
        if self.p.get("inject") == "corrupt" and self.corrupt_addr is None:
            self.corrupt_addr = addr     # the model's word for the first fetched address is off by one bit
        self.expect.append((tag, self.model_read(addr), self.cycle, addr))
        if self.p.get("inject") == "reorder" and not self.reordered and len(self.expect) >= 2:
            a, b = self.expect[-2], self.expect[-1]
            if a[:2] != b[:2]:
                self.expect[-2], self.expect[-1] = b, a
                self.reordered = True


def _streams(p, rng):
    """Per tag a stream (base, length) in SDRAM words, spread over rows and banks."""
    n, L = p["tags"], p["stream_len"]
    space = 1 << p["addr_width"]
    bases = rng.sample(range(0, space // 1024), n)
    return [(b * 1024 + rng.randrange(0, 1024 - L), L) for b in bases]


@cocotb.test()
async def pool(dut):
    p = params()
    bench = PoolBench(dut, p)
    rng = bench.rng
    checker = DFIChecker(dut, p)
    await bench.start()
    cocotb.start_soon(checker.run())
    # --- wait for init_done ---------------------------------------------------
    t0 = get_sim_time("ns")
    try:
        await with_timeout(RisingEdge(dut.init_done), p["init_timeout_cycles"] * SYNC_NS, "ns")
    except SimTimeoutError:
        fail(f"init_done not raised after {p['init_timeout_cycles']} engine clocks")
    if int(dut.init_error.value):
        fail("init_error is set")
    init_ns = get_sim_time("ns") - t0
    await RisingEdge(dut.clk)
    streams = _streams(p, rng)
    tags = len(streams)
    # --- load: host writes every stream word, one offered every write_gap clocks
    words = [(base + k, rng.getrandbits(32)) for base, L in streams for k in range(L)]
    i, gap = 0, 0
    load_start = bench.cycle
    while i < len(words):
        if gap:
            await bench.step({"w_valid": 0})
            gap -= 1
            continue
        addr, word = words[i]
        taken = await bench.step({"w_valid": 1, "w_addr": addr, "w_data": word})
        if "w" in taken:
            bench.model_write(addr, word)
            i += 1
            gap = p["write_gap"] - 1
        else:
            bench.stats["write_stalls"] += 1
    load_cycles = bench.cycle - load_start
    # --- verify a sample by host reads (rast load --verify) ---------------------
    for addr, _ in rng.sample(words, min(p["verify_reads"], len(words))):
        while True:
            taken = await bench.step({"w_valid": 0, "rd_valid": 1, "rd_addr": addr})
            if "rd" in taken:
                bench.host_expect.append((bench.model_read(addr), addr))
                break
    await bench.step({"rd_valid": 0})
    # --- play: the engine's scan, one channel looked at per clock --------------
    # A fetch offered and refused stays offered until taken (the engine's
    # request FIFO holds it the same way), the scan waiting behind it.
    # Stress mode (no consume_period): an answer is consumed at once, so every
    # channel always wants a fetch and the pool is saturated. Rate mode: each
    # channel consumes one word every consume_period clocks (staggered), from
    # a cache that fetches keep `ahead` words ahead of it; consumption starts
    # once every cache is full (and the host writes with it), and a
    # consumption from an empty cache is an underflow.
    pos = [0] * tags
    inflight = [0] * tags
    cached = [0] * tags
    ahead = p["ahead"]
    period = p.get("consume_period")
    consume_from = None
    # aligned: every channel consumes in the same clock (the worst burst of
    # fetch requests); otherwise staggered evenly over the period
    stagger = 0 if p.get("aligned") else max(1, (period or 1) // tags)
    min_cached = ahead
    consumed_at = [None] * tags         # clock of a consumption not yet refilled
    refill = []                         # clocks from a consumption to its cache being full again
    # a second writer overwrites stream words while they are being fetched
    pending_writes = collections.deque()
    fetch_pattern = p.get("fetch_pattern", "1")
    play_start = bench.cycle
    scan, held = 0, None
    for c in range(p["play_cycles"]):
        drive = {"r_valid": 0, "w_valid": 0, "rd_valid": 0}
        if held is None:
            ch, scan = scan, (scan + 1) % tags
            want = cached[ch] + inflight[ch] < ahead and fetch_pattern[c % len(fetch_pattern)] == "1"
        else:
            ch, want = held, True
        if period is not None:
            if consume_from is None and all(k == ahead for k in cached):
                consume_from = c
                bench.stats["prefill_cycles"] = c
            r = None if consume_from is None else (c - consume_from) % period
            if stagger == 0:
                dues = range(tags) if r == 0 else ()
            else:
                dues = (r // stagger,) if r is not None and r % stagger == 0 and r // stagger < tags else ()
            # channel `due` consumes at consume_from + due·stagger + k·period
            for due in dues:
                if True:
                    consumed_at[due] = c
                    min_cached = min(min_cached, cached[due])
                    if cached[due] == 0:
                        bench.stats["underflows"] += 1
                        if bench.stats["underflows"] == 1:
                            bench.stats["first_underflow"] = f"channel {due} at play cycle {c}"
                    else:
                        cached[due] -= 1
                        bench.stats["consumed"] += 1
        if want:
            base, L = streams[ch]
            addr = base + pos[ch]
            drive.update(r_valid=1, r_addr=addr, r_tag=ch)
        if p["mixed_writes"] and (period is None or consume_from is not None):
            if not pending_writes and rng.random() < 1 / p["write_gap"]:
                t = rng.randrange(tags)
                a = streams[t][0] + rng.randrange(streams[t][1])
                pending_writes.append((a, rng.getrandbits(32)))
            if pending_writes:
                a, w = pending_writes[0]
                drive.update(w_valid=1, w_addr=a, w_data=w)
        taken = await bench.step(drive)
        held = None
        if "r" in taken:
            bench.take_fetch(ch, addr)
            inflight[ch] += 1
            pos[ch] = (pos[ch] + 1) % streams[ch][1]
            bench.stats["fetches"] += 1
        elif want:
            bench.stats["refused"] += 1
            held = ch
        if "w" in taken:
            a, w = pending_writes.popleft()
            bench.model_write(a, w)
            bench.stats["play_writes"] += 1
        # answers seen in this step fill their channels' caches
        for ch2 in bench.answered:
            inflight[ch2] -= 1
            if period is not None:
                cached[ch2] += 1
                if cached[ch2] == ahead and consumed_at[ch2] is not None:
                    refill.append(c - consumed_at[ch2])
                    consumed_at[ch2] = None
            if consume_from is not None:
                bench.steady_latencies.append(bench.latencies[-1])   # one answer per clock at most
        bench.answered.clear()
    play_cycles = bench.cycle - play_start
    # --- drain -------------------------------------------------------------------
    for _ in range(p["drain_cycles"]):
        if not bench.expect and not bench.host_expect:
            break
        await bench.step({"r_valid": 0, "w_valid": 0, "rd_valid": 0})
    if bench.expect or bench.host_expect:
        fail(f"{len(bench.expect)} fetches and {len(bench.host_expect)} host reads unanswered "
             f"after {p['drain_cycles']} drain cycles")
    checker.finish()
    lat = sorted(bench.latencies)
    report = {
        "init_us": init_ns / 1000, "load_cycles": load_cycles, "words_loaded": len(words),
        "play_cycles": play_cycles, "stats": dict(bench.stats), "commands": dict(checker.log),
        "refreshes_after_init": len(checker.refs), "max_refresh_gap_ns": checker.max_ref_gap,
        "tREFI_ns": checker.t["tREFI"],
        "latency_cycles": {"min": lat[0], "median": lat[len(lat) // 2], "p99": lat[int(len(lat) * 0.99)],
                           "max": lat[-1]} if lat else None,
        "latency_histogram": dict(collections.Counter(lat)),
        "min_cached_at_consume": min_cached if period is not None else None,
        "max_refill_cycles": max(refill) if refill else None,
        "refills": len(refill),
        "steady_latency_max": max(bench.steady_latencies) if bench.steady_latencies else None,
    }
    (run_dir() / "report.json").write_text(json.dumps(report, indent=1) + "\n")
    if bench.stats["underflows"]:
        fail(f"{bench.stats['underflows']} underflows (a channel consumed from an empty cache), first: "
             f"{bench.stats['first_underflow']}; worst fetch latency {lat[-1] if lat else None} clocks")
    if period is not None and not bench.stats["consumed"]:
        fail("rate mode: the caches never filled, nothing was consumed")
    if checker.violations:
        fail("SDRAM command checks failed:\n" + "\n".join(checker.violations[:20]))
    if p.get("expect_refusals") and not bench.stats["refused"]:
        fail("the fetch load never met r_ready low: back-pressure was not exercised")

