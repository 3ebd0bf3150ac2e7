// rast_uart_chain: simulation-only testbench of the board's replay system
// (UART bridge + replay block, `rast_system`) for the load chain test.
//
// From files in the working directory:
//   cfg.hex  n_rx, n_src, divisor, n_steps, capture_from (one 64-bit hex word each)
//   rx.hex   the host's bytes: bits 7..0 the byte, bits 31..8 idle bit times before it
//   src.hex  input samples (I low), repeated, one per period of the block (valid always 1, as
//            from an ADC: the block takes one in a period's first clock)
// it writes:
//   tx.txt      every byte the bridge sends, hex, one per line
//   writes.txt  every register write on the bus: "step addr data" (hex), the step
//               being the input sample from which it takes effect
//   out.txt     output samples from step capture_from on, hex (I low)
//   summary.txt steps, outputs and position-weighted sums of every output sample
//
// With RAST_SDRAM defined, rast_system is the system on LiteDRAM's simulation
// core (rast.sim.sdram_top.SDRAMSystemTop): its bus is inside `inner`, the
// host sends its first byte only once the controller's initialisation is
// done (a board has long finished it when a host connects), and summary.txt
// also has the step of that, the pool's sticky error and the core's
// initialisation error.
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off WIDTHEXPAND */
/* verilator lint_off WIDTHTRUNC */
/* verilator lint_off BLKSEQ */
/* verilator lint_off DECLFILENAME */

`ifdef RAST_SDRAM
`define RAST_BUS dut.inner
`else
`define RAST_BUS dut
`endif

module rast_uart_chain;
    reg clk = 1'b0;
    always #5 clk = ~clk;
    reg rst = 1'b1;
    reg rx = 1'b1;
    wire tx;
    reg [63:0] cfg [0:4];
    reg [31:0] rxb [0:(1 << 20) - 1];
    reg [31:0] src [0:(1 << 16) - 1];
    wire [63:0] n_rx = cfg[0];
    wire [63:0] n_src = cfg[1];
    wire [63:0] div = cfg[2];
    wire [63:0] n_steps = cfg[3];
    wire [63:0] capture_from = cfg[4];

    reg [63:0] step = 0;
    reg [63:0] src_ptr = 0;
    wire i_ready;
    wire o_valid;
    wire [31:0] y;
    wire overflow;
`ifdef RAST_SDRAM
    wire init_done, init_error, pool_error;
    rast_system dut(.clk(clk), .rst(rst), .rx(rx), .tx(tx),
                    .i__valid(1'b1), .i__ready(i_ready), .i__payload(src[src_ptr[15:0]]),
                    .o__valid(o_valid), .o__ready(1'b1), .o__payload(y), .overflow(overflow),
                    .pool_error(pool_error), .init_done(init_done), .init_error(init_error));
    reg [63:0] init_step = 0;
    reg init_seen = 1'b0, pool_error_seen = 1'b0;
    always @(posedge clk) if (!rst) begin
        if (init_done && !init_seen) begin init_seen <= 1'b1; init_step <= step; end
        if (pool_error) pool_error_seen <= 1'b1;
    end
    wire host_go = init_seen;
`else
    rast_system dut(.clk(clk), .rst(rst), .rx(rx), .tx(tx),
                    .i__valid(1'b1), .i__ready(i_ready), .i__payload(src[src_ptr[15:0]]),
                    .o__valid(o_valid), .o__ready(1'b1), .o__payload(y), .overflow(overflow));
    wire host_go = 1'b1;
`endif

    integer fw, fo, ft, fs;
    // position-weighted sums of every output sample (I and Q sign-extended)
    reg [63:0] s1_i = 0, s2_i = 0, s1_q = 0, s2_q = 0, n_out = 0;
    wire [63:0] yi = {{48{y[15]}}, y[15:0]};
    wire [63:0] yq = {{48{y[31]}}, y[31:16]};

    initial begin
        $readmemh("cfg.hex", cfg);
        $readmemh("rx.hex", rxb, 0, cfg[0] - 1);
        $readmemh("src.hex", src, 0, cfg[1] - 1);
        fw = $fopen("writes.txt", "w");
        fo = $fopen("out.txt", "w");
        ft = $fopen("tx.txt", "w");
        #21 rst = 1'b0;
    end

    // The samples: one per transfer. A bus write taken (w_stb and ready)
    // lands RAST_WRITE_STAGING clocks later and takes effect from the first
    // sample taken in its landing clock or later: it is recorded there.
    localparam WS = `RAST_WRITE_STAGING;
    reg w_taken [0:WS-1];
    reg [31:0] w_addr [0:WS-1];
    reg [31:0] w_data [0:WS-1];
    integer j;
    initial for (j = 0; j < WS; j = j + 1) w_taken[j] = 1'b0;
    always @(posedge clk) if (!rst) begin
        if (w_taken[WS - 1])
            $fwrite(fw, "%h %h %h\n", step, w_addr[WS - 1], w_data[WS - 1]);
        for (j = WS - 1; j > 0; j = j - 1) begin
            w_taken[j] <= w_taken[j - 1]; w_addr[j] <= w_addr[j - 1]; w_data[j] <= w_data[j - 1];
        end
        w_taken[0] <= `RAST_BUS.bus__w_stb && `RAST_BUS.bus__ready;
        w_addr[0] <= `RAST_BUS.bus__addr;
        w_data[0] <= `RAST_BUS.bus__w_data;
        if (i_ready) begin
            step <= step + 1;
            src_ptr <= (src_ptr + 1 == n_src) ? 0 : src_ptr + 1;
        end
        if (o_valid) begin
            s1_i = s1_i + yi;  s2_i = s2_i + s1_i;
            s1_q = s1_q + yq;  s2_q = s2_q + s1_q;
            if (n_out >= capture_from) $fwrite(fo, "%h\n", y);
            n_out = n_out + 1;
        end
        if (step + 1 == n_steps) begin
            fs = $fopen("summary.txt", "w");
            $fwrite(fs, "steps %0d\nouts %0d\ns1_i %h\ns2_i %h\ns1_q %h\ns2_q %h\n",
                    step + 1, n_out, s1_i, s2_i, s1_q, s2_q);
`ifdef RAST_SDRAM
            $fwrite(fs, "init_step %0d\ninit_done %0d\ninit_error %0d\npool_error %0d\n",
                    init_step, init_seen, init_error, pool_error_seen || pool_error);
`endif
            $fclose(fs); $fclose(fw); $fclose(fo); $fclose(ft);
            $finish;
        end
    end

    // The host's bytes, 8N1, LSB first, `div` clocks per bit.
    reg [63:0] k = 0;
    reg [63:0] wait_clk = 0;
    reg [3:0] bitn = 0;
    reg sending = 1'b0;
    always @(posedge clk) if (!rst && k < n_rx && host_go) begin
        if (!sending) begin
            if (wait_clk == 0) wait_clk <= rxb[k][31:8] * div + 1;
            else if (wait_clk == 1) begin
                sending <= 1'b1; bitn <= 0; wait_clk <= div; rx <= 1'b0;     // start bit
            end else wait_clk <= wait_clk - 1;
        end else if (wait_clk > 1) wait_clk <= wait_clk - 1;
        else begin
            if (bitn < 8) begin rx <= rxb[k][bitn]; bitn <= bitn + 1; wait_clk <= div; end
            else if (bitn == 8) begin rx <= 1'b1; bitn <= 9; wait_clk <= div; end   // stop bit
            else begin sending <= 1'b0; wait_clk <= 0; k <= k + 1; end
        end
    end

    // The bridge's bytes: sampled in the middle of each bit.
    reg [7:0] tb;
    reg [3:0] tn = 0;
    reg [63:0] tcount = 0;
    reg receiving = 1'b0;
    always @(posedge clk) if (!rst) begin
        if (!receiving) begin
            if (!tx) begin receiving <= 1'b1; tcount <= div + div / 2; tn <= 0; end
        end else if (tcount > 1) tcount <= tcount - 1;
        else if (tn < 8) begin tb[tn] <= tx; tn <= tn + 1; tcount <= div; end
        else begin
            $fwrite(ft, "%h\n", tb);
            receiving <= 1'b0;        // in the stop bit: wait for the next start
        end
    end
endmodule
