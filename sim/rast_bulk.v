// rast_bulk: simulation-only bulk driver and capture around ${dut_module}.
//
// A template: rast.sim.bulk.bulk_verilog fills in each ${...} field (the DUT's
// module and port names, widths, the observed outputs) and checks that the
// cfg.hex fields below are rast.sim.bulk.CFG_FIELDS. The file protocol and the
// input/output patterns are described in rast.sim.bulk.
// Clocking: by default the wrapper makes its own clock (`always #5`, Icarus).
// RAST_EXTERNAL_CLOCK makes clk a port, one clock cycle per rising edge.
// RAST_BURST_CLOCK makes `tick` a port instead: every change of tick (either
// edge) runs BURST clock cycles of the wrapper and the DUT inside one
// evaluation of the simulator, clk made by a zero-delay oscillator below.
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
/* verilator lint_off WIDTHEXPAND */
/* verilator lint_off WIDTHTRUNC */
/* verilator lint_off BLKSEQ */
/* verilator lint_off PINCONNECTEMPTY */
module rast_bulk (
`ifdef RAST_BURST_CLOCK
    input wire tick /*verilator public_flat_rw*/,
`elsif RAST_EXTERNAL_CLOCK
    input wire clk /*verilator public_flat_rw*/,
`endif
${obs_ports}    input wire start /*verilator public_flat_rw*/,
    output reg done /*verilator public_flat_rd*/,
    output reg [63:0] cycles /*verilator public_flat_rd*/,
    output reg [63:0] in_idx /*verilator public_flat_rd*/,
    output reg [63:0] out_idx /*verilator public_flat_rd*/
);
    // payload widths of the DUT's input and output (output: I low half, Q high half)
    localparam IN_W = ${in_width};
    localparam OUT_W = ${out_width};
    localparam HALF = OUT_W / 2;
    // address widths of the src.hex and regs.hex memories
    localparam SRC_AW = ${src_aw};
    localparam REG_AW = ${reg_aw};
    // cfg.hex lines; the last MAX_CAP, from CAP_BASE, are the capture offsets
    // (ascending, distinct; the first n_cap of them are used)
    localparam N_CFG = ${n_cfg};
    localparam MAX_CAP = ${max_cap};
    localparam CAP_BASE = ${cap_base};
`ifdef RAST_BURST_CLOCK
    // BURST clock cycles per change of tick, in zero simulated time: the
    // change starts the first cycle's rising edge, and each edge of clk
    // schedules the next one (non-blocking, so it lands after every process
    // of this edge has run) until 2 * BURST edges were made; clk ends low.
    // A simulator runs this as 2 * BURST rounds of its evaluation loop
    // (Verilator: raise --converge-limit above that).
    localparam BURST = ${burst};
    reg clk = 1'b0;
    reg tick_seen = 1'b0;
    reg [31:0] half_left = 32'd0;
    always @(posedge tick or negedge tick or posedge clk or negedge clk) begin
        if (tick != tick_seen) begin
            tick_seen <= tick;
            half_left <= 2 * BURST - 1;
            clk <= 1'b1;
        end else if (half_left != 32'd0) begin
            half_left <= half_left - 32'd1;
            clk <= ~half_left[0];
        end
    end
`elsif RAST_EXTERNAL_CLOCK
`else
    reg clk = 1'b0;
    always #${clock_half_ns} clk = ~clk;
`endif
    localparam SRC_DEPTH = 1 << SRC_AW;
    localparam REG_DEPTH = 1 << REG_AW;
    reg [63:0] cfg [0:N_CFG-1];
    wire [63:0] n_src = cfg[0];
    wire [63:0] active = cfg[1];
    wire [63:0] pri = cfg[2];
    wire [63:0] pulses = cfg[3];
    wire [63:0] flush = cfg[4];
    wire [63:0] n_regs = cfg[5];
    wire [63:0] n_out = cfg[6];
    wire [63:0] gap_thresh = cfg[7];
    wire [63:0] gap_max = cfg[8];
    wire [63:0] stall_thresh = cfg[9];
    wire [63:0] seed = cfg[10];
    wire [63:0] cap_mode = cfg[11];
    wire [63:0] n_cap = cfg[12];
    wire [63:0] timeout = cfg[13];
    wire [63:0] drain = cfg[14];
    reg [IN_W-1:0] src [0:SRC_DEPTH-1];
    reg [127:0] regs [0:REG_DEPTH-1];

    // Reset rises at 1 ns, not at time 0: Yosys-written `always @*` blocks only
    // run on an event, and Icarus gives no event for a declaration initialiser,
    // so a reset that is 1 from the start never reaches their outputs (they stay X).
    reg rst = 1'b0;
`ifdef RAST_EXTERNAL_CLOCK
    initial rst = 1'b1;
`elsif RAST_BURST_CLOCK
    initial rst = 1'b1;
`else
    initial #1 rst = 1'b1;
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
    wire [127:0] rcur = regs[rptr[REG_AW-1:0]];
    wire reg_here = (rptr < n_regs) && (rcur[127:64] <= in_idx);
    wire drained = (drain == 64'd0) || (out_idx == in_idx);
    wire in_ready;
    // clocks after a taken write before the next input is offered, so that
    // the write applies to it (the DUT's: it lands that many clocks later)
    reg [7:0] settle_left;
    wire in_valid = running && !in_done && !reg_here && (gap_left == 64'd0) && (settle_left == 8'd0);
    wire [IN_W-1:0] in_payload = (pulse != pulses && pos < active) ? src[src_ptr[SRC_AW-1:0]] : {IN_W{1'b0}};
    wire bus_we = running && reg_here && drained;
    wire bus_ready;         // the DUT takes the write in a cycle with it high
${bus_ready_default}
    wire [31:0] bus_addr = rcur[63:32];
    wire [31:0] bus_data = rcur[31:0];

    // ---- output side
    wire [OUT_W-1:0] out_payload;
    wire out_valid;
    reg out_ready;
    reg [63:0] out_pos, quiet, cap_ptr;
    reg [63:0] s1_i, s2_i, s1_q, s2_q;
    wire signed [HALF-1:0] out_i = out_payload[HALF-1:0];
    wire signed [HALF-1:0] out_q = out_payload[OUT_W-1:HALF];
    wire [63:0] out_i64 = {{(64-HALF){out_i[HALF-1]}}, out_i};
    wire [63:0] out_q64 = {{(64-HALF){out_q[HALF-1]}}, out_q};
    // the offsets ascend, so only the next one can match: cap_ptr walks them
    // within each PRI (one compare per output, whatever MAX_CAP)
    wire cap_more = cap_ptr < n_cap;
    wire [63:0] cap_next = cfg[CAP_BASE + (cap_more ? cap_ptr : 64'd0)];
    wire cap_match = cap_more && out_pos == cap_next;
    wire cap_hit = (cap_mode == 64'd0) || cap_match;
    // 4-state simulators: an output with X/Z bits is counted (and kept out of the checksums)
    wire out_has_x = ((^out_payload) === 1'bx);
    reg [63:0] x_count;

    ${dut_module} dut (
        ${dut_ports}
    );

    function [31:0] lfsr_next(input [31:0] s);
        lfsr_next = {s[30:0], s[31] ^ s[21] ^ s[1] ^ s[0]};
    endfunction

    initial begin
        done = 1'b0;
        cycles = 64'd0;
        in_idx = 64'd0;
        out_idx = 64'd0;
        for (k = 0; k < N_CFG; k = k + 1) cfg[k] = 64'd0;
    end

    always @(posedge clk) begin
        if (!running && !done) begin
            if (start) begin
                if (rst_count == 4'd0) begin
                    $readmemh("cfg.hex", cfg);
                end
                if (rst_count == 4'd1) begin
                    if (n_src != 0) $readmemh("src.hex", src, 0, n_src - 1);
                    if (n_regs > REG_DEPTH) begin
                        $display("rast_bulk: %0d register writes, more than the %0d this wrapper holds (reg_aw)",
                                 n_regs, REG_DEPTH);
                        $finish;
                    end
                    if (n_regs != 0) $readmemh("regs.hex", regs, 0, n_regs - 1);
${preload}                    fd_out = $fopen("out.txt", "w");
                    src_ptr <= 0; pos <= 0; pulse <= 0; flushed <= 0; rptr <= 0; gap_left <= 0; settle_left <= 0;
                    out_pos <= 0; cap_ptr <= 0; quiet <= 0; x_count <= 0; s1_i <= 0; s2_i <= 0; s1_q <= 0; s2_q <= 0;
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
            if (bus_we && bus_ready) begin
                rptr <= rptr + 64'd1;
                settle_left <= 8'd${bus_settle};
            end else if (settle_left != 8'd0) begin
                settle_left <= settle_left - 8'd1;
            end
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
                if ({24'd0, lfsr_in[7:0]} < gap_thresh[31:0])
                    gap_left <= 64'd1 + ({48'd0, lfsr_in[23:8]} & gap_max);
            end else if (!reg_here && gap_left != 64'd0) begin
                gap_left <= gap_left - 64'd1;
            end
            // output side
            lfsr_out <= lfsr_next(lfsr_out);
            out_ready <= ({24'd0, lfsr_out[7:0]} >= stall_thresh[31:0]);
            if (out_valid && out_ready) begin
                if (cap_hit) $fwrite(fd_out, "%h %h %h\n", cycles, out_idx, out_payload);
                if (out_has_x) begin
                    x_count <= x_count + 64'd1;
                end else begin
                    s1_i = s1_i + out_i64;  s2_i = s2_i + s1_i;
                    s1_q = s1_q + out_q64;  s2_q = s2_q + s1_q;
                end
                out_idx <= out_idx + 64'd1;
                out_pos <= (out_pos + 64'd1 == pri) ? 64'd0 : out_pos + 64'd1;
                cap_ptr <= (out_pos + 64'd1 == pri) ? 64'd0 : cap_ptr + {63'd0, cap_match};
                quiet <= 64'd0;
            end else begin
                quiet <= quiet + 64'd1;
            end
            if ((out_valid && out_ready && out_idx + 64'd1 == n_out) || (in_done && quiet >= timeout)) begin
                fd_sum = $fopen("summary.txt", "w");
                $fwrite(fd_sum, "in %0d\nout %0d\ncycles %0d\ntimeout %0d\n",
                        in_idx + ((in_valid && in_ready) ? 1 : 0),
                        out_idx + ((out_valid && out_ready) ? 1 : 0),
                        cycles + 1, (out_valid && out_ready && out_idx + 64'd1 == n_out) ? 0 : 1);
                $fwrite(fd_sum, "s1_i %h\ns2_i %h\ns1_q %h\ns2_q %h\n", s1_i, s2_i, s1_q, s2_q);
                $fwrite(fd_sum, "x_count %0d\n", x_count + ((out_valid && out_ready && out_has_x) ? 1 : 0));
${obs_summary}                $fclose(fd_sum);
                $fclose(fd_out);
                running <= 1'b0;
                done <= 1'b1;
            end
        end
    end
endmodule
