"""Bulk drive and capture: a simulation-only Verilog wrapper around a stream DUT.

Per-cycle Python (a cocotb ``await`` per sample) costs tens of microseconds;
one second of radar time at 20 MHz is 20 M samples. So the wrapper
``rast_bulk`` (``sim/rast_bulk.v``, a Verilog template whose DUT names and
widths :func:`bulk_verilog` fills in) does the per-cycle work in the simulator
and talks to Python through files in the simulator's working directory:

``cfg.hex``   scalar settings, one 64-bit hex word per line (see :data:`CFG_FIELDS`)
``src.hex``   input words (I low), read in order and wrapped modulo ``n_src``
``regs.hex``  register script: ``{at_sample[63:0], addr[31:0], data[31:0]}`` per line,
              applied (one write per clock the DUT takes it, ``bus_ready``) before input
              sample ``at_sample`` is offered (``PortMap.bus_settle`` clocks before)
``out.txt``   captured outputs, ``<cycle> <sample index> <payload>`` in hex per line
``summary.txt`` counts and position-weighted checksums of *every* output sample

Input pattern, per PRI: ``active`` words from ``src.hex`` then ``pri - active``
zero words generated in the wrapper (the idle time between pulses), for
``pulses`` PRIs, then ``flush`` zero words so the pipeline empties. The DUT
sees every sample of the radar time line; only the samples that carry a pulse
cross the file boundary.

Valid gaps: before each input sample a gap of ``1..2**ceil(log2(gap_max))`` cycles is
inserted with probability ``gap_thresh/256`` (a 32-bit LFSR seeded from
``seed``); output ``ready`` is low with probability ``stall_thresh/256``.

Capture: ``cap_mode`` 0 writes every output; 1 writes only outputs whose
position in their PRI is one of ``cap_offset[0..n_cap-1]`` (the radar's
range gates, at most ``MAX_CAP`` = 512: the largest build's turbines, each at its own
range; the wrapper walks them in ascending order, one compare per output). In both modes the wrapper folds every output into two
Fletcher-style 64-bit checksums per lane (``s1 += x; s2 += s1``, wrapping),
which :func:`checksums` reproduces in numpy, so a run that keeps only a few
samples per pulse still proves that all outputs equal the model's.

The wrapper waits for ``start`` (driven by the cocotb testbench after it has
written the files, or tied high by the bare C++ harness) and raises ``done``
when ``n_out`` outputs were seen (or ``timeout`` cycles passed without one).
No Python runs between ``start`` and ``done``. Clocking, chosen by a define:

* ``RAST_BURST_CLOCK`` (``rast.sim.runner``'s bulk builds under Verilator):
  the port is ``tick``, and every change of it runs :data:`BURST_CYCLES` clock
  cycles inside one evaluation (a zero-delay oscillator in the wrapper), so
  what a simulator and cocotb spend per time slot is spent once per burst.
  cocotb's GPI clock (C++) or the bare C++ harness toggles ``tick``. Simulated
  time is then no measure of cycles: the wrapper's ``cycles`` counter is.
* ``RAST_EXTERNAL_CLOCK`` (bulk builds with waves, so that the dump shows
  every cycle): ``clk`` is a port, one cycle per period.
* neither: the wrapper makes its own clock (``always #5``), which is how
  Icarus runs it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

__all__ = ["PortMap", "bulk_verilog", "TEMPLATE", "CFG_FIELDS", "BulkJob", "write_job", "read_outputs",
           "read_summary", "checksums", "src_words", "MAX_CAP", "CLOCK_PERIOD_NS", "BURST_CYCLES", "CLOCK_ENV"]

MAX_CAP = 512
#: Stands for an output sample with X/Z bits (as rast.sim.testbench.X_VALUE).
X_VALUE = -(1 << 62)
CLOCK_PERIOD_NS = 10
#: Clock cycles per change of ``tick`` when the wrapper is built with ``RAST_BURST_CLOCK``.
BURST_CYCLES = 256
#: Set by ``rast.sim.runner.run`` to how the wrapper was built (``Build.clock``):
#: ``clk`` (``RAST_EXTERNAL_CLOCK``: the testbench drives ``clk``, a cycle per
#: period), ``burst`` (``RAST_BURST_CLOCK``: it drives ``tick``, BURST_CYCLES
#: cycles per edge); unset, the wrapper clocks itself.
CLOCK_ENV = "RAST_BULK_CLOCK"

#: Lines of cfg.hex, in order.
CFG_FIELDS = ("n_src", "active", "pri", "pulses", "flush", "n_regs", "n_out", "gap_thresh",
              "gap_max", "stall_thresh", "seed", "cap_mode", "n_cap", "timeout", "drain",
              *[f"cap_offset{k}" for k in range(MAX_CAP)])


@dataclass(frozen=True)
class PortMap:
    """Names (as in the DUT's Verilog) of the ports the wrapper connects."""
    module: str
    in_payload: str
    in_valid: str
    in_ready: str
    in_width: int
    out_payload: str
    out_valid: str
    out_width: int
    out_ready: str | None = None
    bus_addr: str | None = None
    bus_addr_width: int = 0
    bus_w_data: str | None = None
    bus_w_data_width: int = 32
    bus_w_stb: str | None = None
    #: the DUT's bus ready (a write is taken in a cycle with it high); None: always
    bus_ready: str | None = None
    #: clocks after a write is taken in which no input is offered: a write
    #: lands that many clocks later in the DUT and applies to the next input
    bus_settle: int = 0
    #: other DUT inputs tied to constants: name -> (width, value)
    tie: dict = field(default_factory=dict)
    #: DUT outputs brought out to the wrapper's ports (name -> width)
    observe: dict = field(default_factory=dict)
    #: DUT outputs left unconnected
    open_outputs: tuple = ()
    clk: str = "clk"
    rst: str = "rst"
    #: memories inside the DUT the wrapper loads at the start, after the
    #: testbench wrote the files: file name -> hierarchical path from the
    #: wrapper (e.g. a simulated SDRAM's banks, ``BulkJob.images``)
    preload: dict = field(default_factory=dict)


#: The wrapper's Verilog: a template whose ``${name}`` fields :func:`bulk_verilog` fills in.
TEMPLATE = "rast_bulk.v"
_FIELD = re.compile(r"\$\{(\w+)\}")


@lru_cache(maxsize=None)
def _template() -> str:
    text = (resources.files("rast.sim") / TEMPLATE).read_text()
    # the template's named cfg.hex lines must be CFG_FIELDS, in order, then the capture offsets
    named = re.findall(r"^\s*wire \[63:0\] (\w+) = cfg\[(\d+)\];", text, re.M)
    want = [(n, str(i)) for i, n in enumerate(CFG_FIELDS) if not n.startswith("cap_offset")]
    if named != want or CFG_FIELDS[len(want):] != tuple(f"cap_offset{k}" for k in range(MAX_CAP)):
        raise RuntimeError(f"{TEMPLATE}: its cfg.hex lines {named} are not CFG_FIELDS {CFG_FIELDS}")
    return text


def bulk_verilog(p: PortMap, *, src_aw: int = 22, reg_aw: int = 18) -> str:
    """The Verilog text of ``rast_bulk`` wrapping ``p.module``: :data:`TEMPLATE`
    with the DUT's names and widths filled in."""
    conns = [f".{p.clk}(clk)", f".{p.rst}(rst)",
             f".{p.in_payload}(in_payload)", f".{p.in_valid}(in_valid)", f".{p.in_ready}(in_ready)",
             f".{p.out_payload}(out_payload)", f".{p.out_valid}(out_valid)"]
    if p.out_ready:
        conns.append(f".{p.out_ready}(out_ready)")
    if p.bus_addr:
        conns += [f".{p.bus_addr}(bus_addr[{p.bus_addr_width - 1}:0])",
                  f".{p.bus_w_data}(bus_data[{p.bus_w_data_width - 1}:0])",
                  f".{p.bus_w_stb}(bus_we)"]
    if p.bus_ready:
        conns.append(f".{p.bus_ready}(bus_ready)")
    for name, (w, v) in p.tie.items():
        conns.append(f".{name}({w}'d{v})")
    for n in p.observe:
        conns.append(f".{n}(obs_{n})")
    for n in p.open_outputs:
        conns.append(f".{n}()")
    n_fixed = CFG_FIELDS.index("cap_offset0")
    values = dict(
        dut_module=p.module, dut_ports=",\n        ".join(conns),
        obs_ports="".join(f"    output wire [{w - 1}:0] obs_{n} /*verilator public_flat_rd*/,\n"
                          for n, w in p.observe.items()),
        obs_summary="".join(f'                $fwrite(fd_sum, "obs_{n} %0d\\n", obs_{n});\n'
                            for n in p.observe),
        bus_ready_default="" if p.bus_ready else "    assign bus_ready = 1'b1;\n", bus_settle=p.bus_settle,
        preload="".join(f'                    $readmemh("{f}", {path});\n' for f, path in p.preload.items()),
        in_width=p.in_width, out_width=p.out_width, src_aw=src_aw, reg_aw=reg_aw,
        n_cfg=len(CFG_FIELDS), max_cap=MAX_CAP, cap_base=n_fixed, clock_half_ns=CLOCK_PERIOD_NS // 2,
        burst=BURST_CYCLES)
    text = _template()
    unknown = set(_FIELD.findall(text)) - set(values)
    if unknown:
        raise RuntimeError(f"{TEMPLATE}: no value for {sorted(unknown)}")
    return _FIELD.sub(lambda m: str(values[m.group(1)]), text)


# ---------------------------------------------------------------------------
# Python side of the file protocol

@dataclass
class BulkJob:
    """One bulk run: stimulus, register script, capture plan."""
    src: np.ndarray                    # packed input words (uint), I low
    active: int                        # words of src per PRI
    pri: int                           # samples per PRI
    pulses: int
    flush: int = 0
    regs: list = field(default_factory=list)   # [(at_sample, addr, data)], at_sample non-decreasing
    gap_thresh: int = 0                # 0..256: probability/256 of a gap before a sample
    gap_max: int = 1
    stall_thresh: int = 0              # 0..256: probability/256 of out ready low
    seed: int = 1
    cap_offsets: tuple | None = None   # None: capture every output
    timeout: int = 100_000
    drain: bool = False                # wait for the pipeline to empty before register writes
    #: contents of the DUT's memories the wrapper loads at the start
    #: (``PortMap.preload``): file name -> (indices, values), written as hex
    images: dict = field(default_factory=dict)

    @property
    def n_in(self) -> int:
        return self.pulses * self.pri + self.flush

    def validate(self):
        if self.pri < 1 or not 0 <= self.active <= self.pri:
            raise ValueError(f"need 0 <= active <= pri, pri >= 1, not active={self.active} pri={self.pri}")
        if self.active and len(self.src) == 0:
            raise ValueError("active > 0 needs src words")
        if self.cap_offsets is not None and not 0 < len(set(self.cap_offsets)) <= MAX_CAP:
            raise ValueError(f"1..{MAX_CAP} capture offsets, not {len(set(self.cap_offsets))}")
        if self.cap_offsets is not None and not all(0 <= o < self.pri for o in self.cap_offsets):
            raise ValueError(f"capture offsets must be positions in the PRI, 0..{self.pri - 1}")
        ats = [r[0] for r in self.regs]
        if ats != sorted(ats):
            raise ValueError("register script must be in sample order")
        if not (0 <= self.gap_thresh <= 256 and 0 <= self.stall_thresh <= 256):
            raise ValueError("gap_thresh and stall_thresh are probabilities in 1/256, 0..256")


def _hex_lines(values: np.ndarray, digits: int) -> bytes:
    """Fast fixed-width hex, one value per line (uint64 values)."""
    v = np.asarray(values, dtype=np.uint64)
    if v.size == 0:
        return b""
    nib = np.empty((v.size, digits), dtype=np.uint8)
    for d in range(digits):
        nib[:, digits - 1 - d] = (v >> np.uint64(4 * d)) & np.uint64(0xF)
    table = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)
    chars = np.empty((v.size, digits + 1), dtype=np.uint8)
    chars[:, :digits] = table[nib]
    chars[:, digits] = ord("\n")
    return chars.tobytes()


def _memory_image(index, values) -> bytes:
    """``$readmemh`` text: each run of consecutive indices after its ``@address``."""
    index = np.asarray(index, dtype=np.int64)
    values = np.asarray(values, dtype=np.uint64)
    if index.size == 0:
        return b""
    starts = np.flatnonzero(np.diff(index, prepend=index[0] - 2) != 1)
    digits = max(1, -(-int(values.max()).bit_length() // 4))
    out = []
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else len(index)
        out.append(f"@{int(index[start]):x}\n".encode() + _hex_lines(values[start:end], digits))
    return b"".join(out)


def src_words(job: BulkJob) -> np.ndarray:
    """The words ``src.hex`` holds for ``job``: ``job.src``, or its first
    ``active`` words when every pulse's words are those (a pulse train without
    noise). The wrapper reads src.hex in order and wraps at its end, so the
    DUT sees the same input either way; the simulator then parses one pulse
    instead of all of them ($readmemh of 4 M words took 1.4 s of a 23 s run)."""
    src = np.asarray(job.src, dtype=np.uint64)
    a = job.active
    if 0 < a < len(src) and len(src) % a == 0 and (src.reshape(-1, a) == src[:a]).all():
        return src[:a]
    return src


def write_job(job: BulkJob, directory: Path, n_out: int | None = None) -> None:
    """Write ``cfg.hex``, ``src.hex``, ``regs.hex`` and ``job.images`` for ``job`` into ``directory``."""
    job.validate()
    d = Path(directory)
    src = src_words(job)
    cap = sorted(set(job.cap_offsets or []))          # the wrapper walks them in ascending order
    values = dict(n_src=len(src), active=job.active, pri=job.pri, pulses=job.pulses,
                  flush=job.flush, n_regs=len(job.regs), n_out=job.n_in if n_out is None else n_out,
                  gap_thresh=job.gap_thresh,
                  # the wrapper draws 1 + (random & mask): a mask, not a modulo (no divider per cycle)
                  gap_max=(1 << max(0, job.gap_max - 1).bit_length()) - 1,
                  stall_thresh=job.stall_thresh, seed=job.seed,
                  cap_mode=0 if job.cap_offsets is None else 1, n_cap=len(cap),
                  timeout=job.timeout, drain=int(job.drain))
    for k in range(MAX_CAP):
        values[f"cap_offset{k}"] = cap[k] if k < len(cap) else (1 << 63)
    (d / "cfg.hex").write_bytes(_hex_lines(np.array([values[f] for f in CFG_FIELDS], dtype=np.uint64), 16))
    (d / "src.hex").write_bytes(_hex_lines(src if len(src) else np.zeros(1, np.uint64), 8))
    for name, (index, values) in job.images.items():
        (d / name).write_bytes(_memory_image(index, values))
    if job.regs:
        r = np.array(job.regs, dtype=np.uint64).reshape(-1, 3)
        hi = r[:, 0]
        lo = (r[:, 1] << np.uint64(32)) | (r[:, 2] & np.uint64(0xFFFFFFFF))
        (d / "regs.hex").write_bytes(b"".join(
            a[:-1] + b for a, b in zip(_hex_lines(hi, 16).splitlines(keepends=True),
                                       _hex_lines(lo, 16).splitlines(keepends=True))))
    else:
        (d / "regs.hex").write_bytes(b"0\n")
    for stale in ("out.txt", "summary.txt"):
        (d / stale).unlink(missing_ok=True)


def read_outputs(directory: Path, width: int = 16):
    """``(cycles, sample_index, i, q)`` int64 arrays from ``out.txt``."""
    raw = (Path(directory) / "out.txt").read_bytes().split()
    if not raw:
        z = np.zeros(0, np.int64)
        return z, z, z, z
    has_x = np.array([any(c in b"xXzZ" for c in t) for t in raw[2::3]], dtype=bool)
    vals = [0 if any(c in b"xXzZ" for c in t) else int(t, 16) for t in raw]
    cols = np.array(vals, dtype=np.uint64).reshape(-1, 3)
    payload = cols[:, 2].astype(np.int64)
    mask, sign = (1 << width) - 1, 1 << (width - 1)
    i = ((payload & mask) ^ sign) - sign
    q = (((payload >> width) & mask) ^ sign) - sign
    i[has_x] = X_VALUE
    q[has_x] = X_VALUE
    return cols[:, 0].astype(np.int64), cols[:, 1].astype(np.int64), i, q


def read_summary(directory: Path) -> dict:
    out = {}
    for line in (Path(directory) / "summary.txt").read_text().split("\n"):
        if line.strip():
            k, v = line.split()
            out[k] = int(v, 16) if k.startswith("s") and k[1] in "12" else int(v)
    return out


def checksums(i: np.ndarray, q: np.ndarray) -> dict:
    """The wrapper's Fletcher checksums of full output sequences (wrapping uint64)."""
    out = {}
    for name, x in (("i", i), ("q", q)):
        x = np.asarray(x, dtype=np.int64).astype(np.uint64)
        with np.errstate(over="ignore"):
            s1 = np.cumsum(x, dtype=np.uint64)
            out[f"s1_{name}"] = int(s1[-1]) if s1.size else 0
            out[f"s2_{name}"] = int(np.sum(s1, dtype=np.uint64)) if s1.size else 0
    return out
