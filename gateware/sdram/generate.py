"""LiteDRAM's standalone core, generated at build time and cached.

:func:`generate_core` runs LiteDRAM's own generator (``python -m litedram.gen
CONFIG --no-compile``, the ``litedram_gen`` command) on a YAML config kept in
this folder and returns what the Amaranth side needs: the Verilog, the CSR
map of its ``wb_ctrl`` bus (``csr.csv``), the DFII initialisation sequence
the generator wrote for LiteX's BIOS (``sdram_phy.h``, ``init_sequence()``),
and the module's timings as LiteDRAM computed them for the clock.

The output goes to ``<repo>/build/litedram/<name>-<key>/`` (or under
``$RAST_LITEDRAM_CACHE``), ``key`` a hash of the config's text, the variant
(hardware or ``--sim``), the LiteX/LiteDRAM/Migen versions and
:data:`GENERATOR_SCHEMA`. Nothing generated is checked in.

The ``--sim`` variant (LiteDRAM's ``SDRAMPHYModel`` in place of the PHY and
pins) writes its Verilog and then tries to build LiteX's own C++ simulator,
which needs a ``pythondata-misc-tapcfg`` package that is not on the package
registry; the command then exits 1 with that ImportError. That failure, and
only that one, is accepted once the Verilog and ``csr.csv`` are written.
"""

from __future__ import annotations

import csv
import fcntl
import hashlib
import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["DEFAULT_CONFIG", "GENERATOR_SCHEMA", "CORE_NAME", "InitOp", "GeneratedCore",
           "generate_core", "parse_init_sequence", "LiteDRAMGenError"]

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
DEFAULT_CONFIG = HERE / "ulx3s_sdram.yml"
CORE_NAME = "litedram_core"
#: Bump when what this module derives from the generator's output changes.
GENERATOR_SCHEMA = 1
_TOOLS = ("litex", "litedram", "migen", "liteeth", "litescope")


class LiteDRAMGenError(RuntimeError):
    pass


@dataclass(frozen=True)
class InitOp:
    """One step of the initialisation: a ``wb_ctrl`` register write (``addr`` a
    byte address from ``csr.csv``) or a wait of ``cdelay`` units."""
    kind: str            # "write" or "wait"
    addr: int = 0
    data: int = 0
    cdelay: int = 0
    comment: str = ""


@dataclass(frozen=True)
class GeneratedCore:
    directory: Path
    sim: bool
    verilog_path: Path
    csr: dict                 # register name -> byte address on wb_ctrl
    init_ops: tuple           # InitOp, the BIOS's init_sequence() in order
    sys_clk_freq: float
    cl: int                   # CAS latency of the mode register the sequence writes
    port_addr_width: int      # native user port: word address bits
    port_data_width: int
    timings: dict = field(default_factory=dict)   # LiteDRAM's, in clocks, and the module's in ns
    geometry: dict = field(default_factory=dict)

    @property
    def verilog(self) -> str:
        return self.verilog_path.read_text()


def _versions() -> dict:
    from importlib.metadata import version
    return {t: version(t) for t in _TOOLS}


def _cache_root() -> Path:
    env = os.environ.get("RAST_LITEDRAM_CACHE")
    return Path(env) if env else REPO_ROOT / "build" / "litedram"


def _load_config(path: Path) -> dict:
    import yaml
    cfg = yaml.safe_load(path.read_text())
    if not isinstance(cfg, dict):
        raise LiteDRAMGenError(f"LiteDRAM config {path.name} must be a YAML mapping")
    return cfg


def _flag_value(expr: str, defines: dict) -> int:
    v = 0
    for part in expr.split("|"):
        part = part.strip()
        if part in defines:
            v |= defines[part]
        else:
            v |= int(part, 0)
    return v


def parse_init_sequence(header: str, csr: dict) -> tuple:
    """The register writes and waits of ``init_sequence()`` in the generator's
    ``sdram_phy.h``: ``sdram_dfii_*_write(v)`` -> a write of that register,
    ``command_p0(c)`` -> writes of ``pi0_command`` and ``pi0_command_issue``,
    ``cdelay(n)`` -> a wait. Anything else in the function is an error (so a
    new LiteDRAM with another sequence is noticed, not half-followed)."""
    defines = {m.group(1): int(m.group(2), 0)
               for m in re.finditer(r"^#define\s+(DFII_\w+)\s+(0x[0-9a-fA-F]+|\d+)\s*$", header, re.M)}
    m = re.search(r"static inline void init_sequence\(void\)\s*\{(.*?)\n\}", header, re.S)
    if not m:
        raise LiteDRAMGenError("sdram_phy.h has no init_sequence()")
    ops, comment = [], ""
    for line in m.group(1).splitlines():
        line = line.strip()
        if not line:
            continue
        c = re.fullmatch(r"/\*\s*(.*?)\s*\*/", line)
        if c:
            comment = c.group(1)
            continue
        w = re.fullmatch(r"(sdram_dfii_\w+)_write\((.+)\);", line)
        if w:
            reg = w.group(1)
            if reg not in csr:
                raise LiteDRAMGenError(f"init_sequence() writes {reg}, which csr.csv does not list")
            ops.append(InitOp("write", csr[reg], _flag_value(w.group(2), defines), comment=comment))
            continue
        w = re.fullmatch(r"command_p0\((.+)\);", line)
        if w:
            ops.append(InitOp("write", csr["sdram_dfii_pi0_command"], _flag_value(w.group(1), defines),
                              comment=comment))
            ops.append(InitOp("write", csr["sdram_dfii_pi0_command_issue"], 1, comment=comment))
            continue
        w = re.fullmatch(r"cdelay\((\d+)\);", line)
        if w:
            ops.append(InitOp("wait", cdelay=int(w.group(1)), comment=comment))
            continue
        raise LiteDRAMGenError(f"init_sequence(): cannot follow {line!r}")
    return tuple(ops)


def _read_csr(path: Path) -> dict:
    regs = {}
    with open(path, newline="") as f:
        for row in csv.reader(f):
            if row and row[0] == "csr_register":
                regs[row[1]] = int(row[2], 0)
    return regs


def _timings(cfg: dict) -> tuple[dict, dict]:
    from litedram import modules
    mod_cls = getattr(modules, cfg["sdram_module"])
    f = float(cfg["sys_clk_freq"])
    mod = mod_cls(f, "1:1")
    ts = mod.timing_settings
    clocks = {k: getattr(ts, k) for k in ("tRP", "tRCD", "tWR", "tWTR", "tREFI", "tRFC", "tRAS", "tRC",
                                         "tRRD", "tCCD")}
    sg = mod_cls.speedgrade_timings["default"]
    tech = mod_cls.technology_timings

    def ns(v):
        # LiteDRAM writes a timing as ns, or (clocks, ns) meaning max(clocks·tCK, ns)
        if v is None:
            return None
        if isinstance(v, tuple):
            c, t = v
            return max((c or 0) * 1e9 / f, t or 0)
        return float(v)
    ns_t = {k: ns(getattr(sg, k)) for k in ("tRP", "tRCD", "tWR", "tRFC", "tRAS") if hasattr(sg, k)}
    ns_t.update({k: ns(getattr(tech, k)) for k in ("tREFI", "tWTR", "tRRD", "tCCD")})
    g = mod.geom_settings
    geom = {"bankbits": g.bankbits, "rowbits": g.rowbits, "colbits": g.colbits,
            "module": cfg["sdram_module"]}
    return {"clocks": clocks, "ns": ns_t, "tck_ns": 1e9 / f}, geom


def generate_core(config: Path | str = DEFAULT_CONFIG, *, sim: bool = False,
                  cache_root: Path | None = None) -> GeneratedCore:
    """Generate (once per key) and describe LiteDRAM's core for ``config``."""
    config = Path(config)
    text = config.read_text()
    cfg = _load_config(config)
    ports = cfg.get("user_ports") or {}
    if list(ports) != ["stream"] or ports["stream"].get("type") != "native":
        raise LiteDRAMGenError("the LiteDRAM config must have exactly one user port, 'stream', of type native")
    key_src = json.dumps({"config": text, "sim": bool(sim), "tools": _versions(),
                          "schema": GENERATOR_SCHEMA, "name": CORE_NAME}, sort_keys=True)
    key = hashlib.sha256(key_src.encode()).hexdigest()[:16]
    root = Path(cache_root) if cache_root is not None else _cache_root()
    out = root / f"{CORE_NAME}{'-sim' if sim else ''}-{key}"
    out.mkdir(parents=True, exist_ok=True)
    stamp = out / "GENERATED_OK"
    verilog = out / "gateware" / f"{CORE_NAME}.v"
    with open(out / ".lock", "w") as lockf:
        fcntl.flock(lockf, fcntl.LOCK_EX)
        try:
            if not stamp.exists():
                (out / "config.yml").write_text(text)
                cmd = [sys.executable, "-m", "litedram.gen", "config.yml", "--no-compile",
                       "--output-dir", ".", "--name", CORE_NAME] + (["--sim"] if sim else [])
                proc = subprocess.run(cmd, cwd=out, capture_output=True, text=True)
                (out / "litedram_gen.log").write_text(proc.stdout + proc.stderr)
                written = verilog.exists() and (out / "csr.csv").exists()
                tapcfg_only = "pythondata-misc-tapcfg module not installed" in proc.stderr
                if proc.returncode != 0 and not (sim and written and tapcfg_only):
                    raise LiteDRAMGenError(f"litedram_gen failed (exit {proc.returncode}) in {out}:\n"
                                           + (proc.stdout + proc.stderr)[-3000:])
                if not written:
                    raise LiteDRAMGenError(f"litedram_gen wrote no {verilog.name} in {out}")
                stamp.write_text(key_src + "\n")
        finally:
            fcntl.flock(lockf, fcntl.LOCK_UN)
    csr = _read_csr(out / "csr.csv")
    header = (out / "software" / "include" / "generated" / "sdram_phy.h").read_text()
    ops = parse_init_sequence(header, csr)
    cl = int(re.search(r"#define SDRAM_PHY_CL (\d+)", header).group(1))
    m = re.search(r"input\s+wire\s+\[(\d+):0\]\s+user_port_stream_cmd_addr", verilog.read_text())
    timings, geom = _timings(cfg)
    return GeneratedCore(directory=out, sim=bool(sim), verilog_path=verilog, csr=csr, init_ops=ops,
                         sys_clk_freq=float(cfg["sys_clk_freq"]), cl=cl,
                         port_addr_width=int(m.group(1)) + 1,
                         port_data_width=int(ports["stream"].get("data_width", 16)),
                         timings=timings, geometry=geom)
