"""Build the bare Verilator C++ harness (``main.cpp``) around the bulk wrapper.

Same Verilog as the cocotb build (``rast.sim.top.top_sources``), clocked as
the cocotb bulk build is (``runner.BURST_CLOCK_ARGS``: ``tick`` toggled, a
burst of cycles per evaluation) or, with ``clock="clk"``, a cycle per two
evaluations (``runner.EXTERNAL_CLOCK_ARGS``), the C++ at ``-O3`` as in the
cocotb bulk build, no ``--vpi``/``--public-flat-rw``, the same waived warning
classes. Cached like the cocotb builds, per Verilog hash and flags.
"""

from __future__ import annotations

import fcntl
import hashlib
from pathlib import Path

from rast.gateware.verilog import build_verilated, setup_verilator
from rast.sim import runner

__all__ = ["build_harness"]

HERE = Path(__file__).resolve().parent


def build_harness(sources: dict[str, str], toplevel: str = "rast_bulk", jobs: int = 2,
                  extra_args: tuple[str, ...] = (), clock: str = "burst") -> Path:
    """Return the path of the harness executable for ``sources``, built with
    ``extra_args`` added to Verilator's command (flag trials of ``bench_cosim``);
    ``clock`` "burst" (as the cocotb bulk build) or "clk" (a cycle per two
    evaluations)."""
    if clock not in ("burst", "clk"):
        raise ValueError(f"clock must be 'burst' or 'clk', not {clock!r}")
    setup_verilator()
    main = (HERE / "main.cpp").read_text()
    h = hashlib.sha256(main.encode())
    clock_args = ((*runner.BURST_CLOCK_ARGS, "-CFLAGS", "-DRAST_BURST_CLOCK") if clock == "burst"
                  else runner.EXTERNAL_CLOCK_ARGS)
    flags = (*clock_args, *runner.BULK_CFLAGS, *runner.split_args(sources), *extra_args)
    h.update("\0".join(flags).encode())
    for k in sorted(sources):
        h.update(k.encode() + sources[k].encode())
    bdir = runner.SIM_BUILD / f"harness-{toplevel}-{h.hexdigest()[:16]}"
    bdir.mkdir(parents=True, exist_ok=True)
    exe = bdir / "obj_dir" / "harness"
    with open(bdir / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if exe.exists():
            return exe
        paths = []
        for k, v in sources.items():
            (bdir / k).write_text(v)
            paths.append(str(bdir / k))
        build_verilated(["--cc", "--exe", "--build", "-j", str(jobs),
                         "--top-module", toplevel, "-o", "harness", *flags, str(HERE / "main.cpp"), *paths],
                        bdir, "the bare harness")
    return exe
