"""Build the bare Verilator C++ harness (``main.cpp``) around the bulk wrapper.

Same Verilog as the cocotb build (``rast.sim.top.top_sources``), clock made a
port with ``-DRAST_EXTERNAL_CLOCK``, no ``--vpi``/``--public-flat-rw``, the
same waived warning classes. Cached like the cocotb builds, per Verilog hash.
"""

from __future__ import annotations

import fcntl
import hashlib
from pathlib import Path

from rast.gateware.verilog import build_verilated, setup_verilator
from rast.sim import runner

__all__ = ["build_harness"]

HERE = Path(__file__).resolve().parent


def build_harness(sources: dict[str, str], toplevel: str = "rast_bulk", jobs: int = 2) -> Path:
    """Return the path of the harness executable for ``sources``."""
    setup_verilator()
    main = (HERE / "main.cpp").read_text()
    h = hashlib.sha256(main.encode())
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
        build_verilated(["--cc", "--exe", "--build", "-j", str(jobs), "-DRAST_EXTERNAL_CLOCK",
                         "--top-module", toplevel, "-o", "harness", str(HERE / "main.cpp"), *paths],
                        bdir, "the bare harness")
    return exe
