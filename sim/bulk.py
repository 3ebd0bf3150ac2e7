"""Bulk drive and capture: a simulation-only Verilog wrapper around a stream DUT.

Per-cycle Python (a cocotb ``await`` per sample) costs tens of microseconds;
one second of radar time at 20 MHz is 20 M samples. So the wrapper
``rast_bulk`` generated here does the per-cycle work in the simulator and
talks to Python through files in the simulator's working directory:

``cfg.hex``   scalar settings, one 64-bit hex word per line (see :data:`CFG_FIELDS`)
``src.hex``   input words (I low), read in order and wrapped modulo ``n_src``
``regs.hex``  register script: ``{at_sample[63:0], addr[31:0], data[31:0]}`` per line,
              applied (one write per clock) before input sample ``at_sample`` is offered
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
range gates). In both modes the wrapper folds every output into two
Fletcher-style 64-bit checksums per lane (``s1 += x; s2 += s1``, wrapping),
which :func:`checksums` reproduces in numpy, so a run that keeps only a few
samples per pulse still proves that all outputs equal the model's.

The wrapper waits for ``start`` (driven by the cocotb testbench after it has
written the files, or tied high by the bare C++ harness) and raises ``done``
when ``n_out`` outputs were seen (or ``timeout`` cycles passed without one).
The clock is generated inside (``always #5``, needs ``--timing`` in
Verilator), so no Python runs between ``start`` and ``done``; define
``RAST_EXTERNAL_CLOCK`` to make ``clk`` a port for the bare harness.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["PortMap", "bulk_verilog", "CFG_FIELDS", "BulkJob", "write_job", "read_outputs",
           "read_summary", "checksums", "MAX_CAP", "CLOCK_PERIOD_NS"]

MAX_CAP = 8
#: Stands for an output sample with X/Z bits (as rast.sim.testbench.X_VALUE).
X_VALUE = -(1 << 62)
CLOCK_PERIOD_NS = 10

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
    #: other DUT inputs tied to constants: name -> (width, value)
    tie: dict = field(default_factory=dict)
    #: DUT outputs brought out to the wrapper's ports (name -> width)
    observe: dict = field(default_factory=dict)
    #: DUT outputs left unconnected
    open_outputs: tuple = ()
    clk: str = "clk"
    rst: str = "rst"


def bulk_verilog(p: PortMap, *, src_aw: int = 22, reg_aw: int = 18) -> str:
    """The Verilog text of ``rast_bulk`` wrapping ``p.module``."""
    ow = p.out_width
    half = ow // 2
    conns = [f".{p.clk}(clk)", f".{p.rst}(rst)",
             f".{p.in_payload}(in_payload)", f".{p.in_valid}(in_valid)", f".{p.in_ready}(in_ready)",
             f".{p.out_payload}(out_payload)", f".{p.out_valid}(out_valid)"]
    if p.out_ready:
        conns.append(f".{p.out_ready}(out_ready)")
    if p.bus_addr:
        conns += [f".{p.bus_addr}(bus_addr[{p.bus_addr_width - 1}:0])",
                  f".{p.bus_w_data}(bus_data[{p.bus_w_data_width - 1}:0])",
                  f".{p.bus_w_stb}(bus_we)"]
    for name, (w, v) in p.tie.items():
        conns.append(f".{name}({w}'d{v})")
    obs_ports = "".join(f"    output wire [{w - 1}:0] obs_{n},\n" for n, w in p.observe.items())
    for n in p.observe:
        conns.append(f".{n}(obs_{n})")
    for n in p.open_outputs:
        conns.append(f".{n}()")
    nf = len(CFG_FIELDS)
    cfg_idx = {n: i for i, n in enumerate(CFG_FIELDS)}
    cfg_wires = "\n".join(f"    wire [63:0] {n} = cfg[{i}];" for n, i in cfg_idx.items()
                          if not n.startswith("cap_offset"))
    obs_summary = "".join(f'                $fwrite(fd_sum, "obs_{n} %0d\\n", obs_{n});\n' for n in p.observe)
    cap_match = " || ".join(f"(n_cap > {k} && out_pos == cfg[{cfg_idx[f'cap_offset{k}']}])"
                            for k in range(MAX_CAP))
    return f"""// Generated by rast.sim.bulk: simulation-only bulk driver around {p.module}.
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
/* verilator lint_off WIDTHEXPAND */
/* verilator lint_off WIDTHTRUNC */
/* verilator lint_off BLKSEQ */
/* verilator lint_off PINCONNECTEMPTY */
module rast_bulk (
`ifdef RAST_EXTERNAL_CLOCK
    input wire clk,
`endif
{obs_ports}    input wire start,
    output reg done,
    output reg [63:0] cycles,
    output reg [63:0] in_idx,
    output reg [63:0] out_idx
);
`ifndef RAST_EXTERNAL_CLOCK
    reg clk = 1'b0;
    always #{CLOCK_PERIOD_NS // 2} clk = ~clk;
`endif
    localparam SRC_DEPTH = {1 << src_aw};
    localparam REG_DEPTH = {1 << reg_aw};
    reg [63:0] cfg [0:{nf - 1}];
{cfg_wires}
    reg [{p.in_width - 1}:0] src [0:SRC_DEPTH-1];
    reg [127:0] regs [0:REG_DEPTH-1];

    // Reset rises at 1 ns, not at time 0: Yosys-written `always @*` blocks only
    // run on an event, and Icarus gives no event for a declaration initialiser,
    // so a reset that is 1 from the start never reaches their outputs (they stay X).
    reg rst = 1'b0;
`ifndef RAST_EXTERNAL_CLOCK
    initial #1 rst = 1'b1;
`else
    initial rst = 1'b1;
`endif
    reg running = 1'b0;
    reg [3:0] rst_count = 4'd0;
    integer fd_out;
    integer fd_sum;
    integer k;

    // ---- input side
    reg [63:0] src_ptr, pos, pulse, flushed, rptr, gap_left;
    reg [31:0] lfsr_in, lfsr_out;
    wire in_done = (pulse == pulses) && (flushed == flush);
    wire [127:0] rcur = regs[rptr[{reg_aw - 1}:0]];
    wire reg_here = (rptr < n_regs) && (rcur[127:64] <= in_idx);
    wire drained = (drain == 64'd0) || (out_idx == in_idx);
    wire in_ready;
    wire in_valid = running && !in_done && !reg_here && (gap_left == 64'd0);
    wire [{p.in_width - 1}:0] in_payload = (pulse != pulses && pos < active) ? src[src_ptr[{src_aw - 1}:0]] : {p.in_width}'d0;
    wire bus_we = running && reg_here && drained;
    wire [31:0] bus_addr = rcur[63:32];
    wire [31:0] bus_data = rcur[31:0];

    // ---- output side
    wire [{ow - 1}:0] out_payload;
    wire out_valid;
    reg out_ready;
    reg [63:0] out_pos, quiet;
    reg [63:0] s1_i, s2_i, s1_q, s2_q;
    wire signed [{half - 1}:0] out_i = out_payload[{half - 1}:0];
    wire signed [{half - 1}:0] out_q = out_payload[{ow - 1}:{half}];
    wire [63:0] out_i64 = {{{{{64 - half}{{out_i[{half - 1}]}}}}, out_i}};
    wire [63:0] out_q64 = {{{{{64 - half}{{out_q[{half - 1}]}}}}, out_q}};
    wire cap_hit = (cap_mode == 64'd0) || {cap_match};
    // 4-state simulators: an output with X/Z bits is counted (and kept out of the checksums)
    wire out_has_x = ((^out_payload) === 1'bx);
    reg [63:0] x_count;

    {p.module} dut (
        {(','+chr(10)+'        ').join(conns)}
    );

    function [31:0] lfsr_next(input [31:0] s);
        lfsr_next = {{s[30:0], s[31] ^ s[21] ^ s[1] ^ s[0]}};
    endfunction

    initial begin
        done = 1'b0;
        cycles = 64'd0;
        in_idx = 64'd0;
        out_idx = 64'd0;
        for (k = 0; k < {nf}; k = k + 1) cfg[k] = 64'd0;
    end

    always @(posedge clk) begin
        if (!running && !done) begin
            if (start) begin
                if (rst_count == 4'd0) begin
                    $readmemh("cfg.hex", cfg);
                end
                if (rst_count == 4'd1) begin
                    if (n_src != 0) $readmemh("src.hex", src, 0, n_src - 1);
                    if (n_regs != 0) $readmemh("regs.hex", regs, 0, n_regs - 1);
                    fd_out = $fopen("out.txt", "w");
                    src_ptr <= 0; pos <= 0; pulse <= 0; flushed <= 0; rptr <= 0; gap_left <= 0;
                    out_pos <= 0; quiet <= 0; x_count <= 0; s1_i <= 0; s2_i <= 0; s1_q <= 0; s2_q <= 0;
                    lfsr_in <= seed[31:0] | 32'd1;
                    lfsr_out <= (seed[63:32] ^ 32'h5a5a_a5a5) | 32'd1;
                    out_ready <= 1'b1;
                end
                if (rst_count == 4'd7) begin
                    rst <= 1'b0;
                    running <= 1'b1;
                end
                rst_count <= rst_count + 4'd1;
            end
        end else if (running) begin
            cycles <= cycles + 64'd1;
            if (bus_we) rptr <= rptr + 64'd1;
            if (in_valid && in_ready) begin
                in_idx <= in_idx + 64'd1;
                if (pulse == pulses) begin
                    flushed <= flushed + 64'd1;
                end else begin
                    if (pos < active) src_ptr <= (src_ptr + 64'd1 == n_src) ? 64'd0 : src_ptr + 64'd1;
                    if (pos + 64'd1 == pri) begin
                        pos <= 64'd0;
                        pulse <= pulse + 64'd1;
                    end else begin
                        pos <= pos + 64'd1;
                    end
                end
                lfsr_in <= lfsr_next(lfsr_next(lfsr_in));
                if ({{24'd0, lfsr_in[7:0]}} < gap_thresh[31:0])
                    gap_left <= 64'd1 + ({{48'd0, lfsr_in[23:8]}} & gap_max);
            end else if (!reg_here && gap_left != 64'd0) begin
                gap_left <= gap_left - 64'd1;
            end
            // output side
            lfsr_out <= lfsr_next(lfsr_out);
            out_ready <= ({{24'd0, lfsr_out[7:0]}} >= stall_thresh[31:0]);
            if (out_valid && out_ready) begin
                if (cap_hit) $fwrite(fd_out, "%h %h %h\\n", cycles, out_idx, out_payload);
                if (out_has_x) begin
                    x_count <= x_count + 64'd1;
                end else begin
                    s1_i = s1_i + out_i64;  s2_i = s2_i + s1_i;
                    s1_q = s1_q + out_q64;  s2_q = s2_q + s1_q;
                end
                out_idx <= out_idx + 64'd1;
                out_pos <= (out_pos + 64'd1 == pri) ? 64'd0 : out_pos + 64'd1;
                quiet <= 64'd0;
            end else begin
                quiet <= quiet + 64'd1;
            end
            if ((out_valid && out_ready && out_idx + 64'd1 == n_out) || (in_done && quiet >= timeout)) begin
                fd_sum = $fopen("summary.txt", "w");
                $fwrite(fd_sum, "in %0d\\nout %0d\\ncycles %0d\\ntimeout %0d\\n",
                        in_idx + ((in_valid && in_ready) ? 1 : 0),
                        out_idx + ((out_valid && out_ready) ? 1 : 0),
                        cycles + 1, (out_valid && out_ready && out_idx + 64'd1 == n_out) ? 0 : 1);
                $fwrite(fd_sum, "s1_i %h\\ns2_i %h\\ns1_q %h\\ns2_q %h\\n", s1_i, s2_i, s1_q, s2_q);
                $fwrite(fd_sum, "x_count %0d\\n", x_count + ((out_valid && out_ready && out_has_x) ? 1 : 0));
{obs_summary}
                $fclose(fd_sum);
                $fclose(fd_out);
                running <= 1'b0;
                done <= 1'b1;
            end
        end
    end
endmodule
"""


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

    @property
    def n_in(self) -> int:
        return self.pulses * self.pri + self.flush

    def validate(self):
        if self.pri < 1 or not 0 <= self.active <= self.pri:
            raise ValueError(f"need 0 <= active <= pri, pri >= 1, not active={self.active} pri={self.pri}")
        if self.active and len(self.src) == 0:
            raise ValueError("active > 0 needs src words")
        if self.cap_offsets is not None and not 0 < len(self.cap_offsets) <= MAX_CAP:
            raise ValueError(f"1..{MAX_CAP} capture offsets, not {len(self.cap_offsets)}")
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


def write_job(job: BulkJob, directory: Path, n_out: int | None = None) -> None:
    """Write ``cfg.hex``, ``src.hex`` and ``regs.hex`` for ``job`` into ``directory``."""
    job.validate()
    d = Path(directory)
    cap = list(job.cap_offsets or [])
    values = dict(n_src=len(job.src), active=job.active, pri=job.pri, pulses=job.pulses,
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
    (d / "src.hex").write_bytes(_hex_lines(np.asarray(job.src, dtype=np.uint64) if len(job.src)
                                           else np.zeros(1, np.uint64), 8))
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
