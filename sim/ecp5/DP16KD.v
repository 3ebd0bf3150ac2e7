// DP16KD: behavioural simulation model of the ECP5 16 kbit true dual-port
// block RAM (sysMEM EBR), written for RAST's netlist cosimulation from
// Lattice's ECP5 memory usage guide (TN1264). Yosys's ECP5 library ships
// this cell as an empty stub; this module replaces it.
//
// What is modelled (docs/netlist_sim.md has the readings taken and why):
// * DATA_WIDTH_A = DATA_WIDTH_B in {1, 2, 4, 9, 18}, data on DI/DO[W-1:0].
//   AD[13:0] is a bit address: the word is AD[13:s] with s = 0, 1, 2, 3, 4
//   for x1, x2, x4, x9, x18. At x18, AD[1:0] are the byte write enables
//   (AD[0]: bits 8:0, AD[1]: bits 17:9); below x18 the address bits under
//   the word address are ignored.
// * a port is selected when CS[2:0] equals its CSDECODE; CE gates the whole
//   port (read, write, the read latch and its reset); a write (WE) of a
//   selected, enabled port stores the data at the clock edge.
// * the read latch (DO in REGMODE "NOREG") loads the addressed word at the
//   clock edge of an enabled, selected read; on a write it follows
//   WRITEMODE: "NORMAL" keeps its value, "WRITETHROUGH" shows the new word,
//   "READBEFOREWRITE" the old one.
// * REGMODE "OUTREG": DO is a register loading the read latch at a clock
//   edge with OCE high (one more cycle of read latency).
// * RST clears the port's output stage (the latch with NOREG, the register
//   with OUTREG), never the memory. RESETMODE "SYNC": at a clock edge, and
//   only when that stage's clock enable is high (CE for the latch, OCE for
//   the register); define RAST_ECP5_SYNC_RESET_UNGATED for the other
//   reading (reset whatever the enables). RESETMODE "ASYNC": at once.
// * power-up: the memory holds INITVAL_00..3F (x18 only: word k is
//   INITVAL_<k/16>[20*(k%16) +: 18]; other widths must have all-zero
//   INITVALs), DO and the read latch are 0 (configuration clears them, as
//   the global reset does).
// * a read of a word that the other port writes at the same clock edge is
//   undefined on the device (no read-before-write across ports): the read
//   latch gets X (4-state simulators) or, in Verilator (2-state), the old
//   word with every bit inverted, so a design that uses such a read differs
//   from its model; each such read is reported ("DP16KD ... collision").
//   Two writes to one word at one edge stop the simulation ($fatal).
//
// Anything else (other widths, mixed widths, inverted or constant pin
// muxes, unknown mode strings, INIT_DATA "DYNAMIC") stops the simulation at
// time 0 with $fatal: a mode that is not modelled never silently runs.
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
/* verilator lint_off WIDTHEXPAND */
/* verilator lint_off WIDTHTRUNC */
/* verilator lint_off MULTIDRIVEN */
/* verilator lint_off DECLFILENAME */
/* verilator lint_off BLKSEQ */
module DP16KD (
    input DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4, DIA3, DIA2, DIA1, DIA0,
    input ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0,
    input CEA, OCEA, CLKA, WEA, RSTA,
    input CSA2, CSA1, CSA0,
    output DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3, DOA2, DOA1, DOA0,
    input DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4, DIB3, DIB2, DIB1, DIB0,
    input ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0,
    input CEB, OCEB, CLKB, WEB, RSTB,
    input CSB2, CSB1, CSB0,
    output DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3, DOB2, DOB1, DOB0
);
    parameter DATA_WIDTH_A = 18;
    parameter DATA_WIDTH_B = 18;
    parameter REGMODE_A = "NOREG";
    parameter REGMODE_B = "NOREG";
    parameter RESETMODE = "SYNC";
    parameter ASYNC_RESET_RELEASE = "SYNC";
    parameter CSDECODE_A = "0b000";
    parameter CSDECODE_B = "0b000";
    parameter WRITEMODE_A = "NORMAL";
    parameter WRITEMODE_B = "NORMAL";
    parameter GSR = "ENABLED";
    parameter INIT_DATA = "STATIC";
    parameter WID = 0;
    parameter CEAMUX = "CEA";
    parameter OCEAMUX = "OCEA";
    parameter CLKAMUX = "CLKA";
    parameter WEAMUX = "WEA";
    parameter RSTAMUX = "RSTA";
    parameter CS2AMUX = "CS2A";
    parameter CS1AMUX = "CS1A";
    parameter CS0AMUX = "CS0A";
    parameter CEBMUX = "CEB";
    parameter OCEBMUX = "OCEB";
    parameter CLKBMUX = "CLKB";
    parameter WEBMUX = "WEB";
    parameter RSTBMUX = "RSTB";
    parameter CS2BMUX = "CS2B";
    parameter CS1BMUX = "CS1B";
    parameter CS0BMUX = "CS0B";
    parameter [319:0] INITVAL_00 = 320'h0;
    parameter [319:0] INITVAL_01 = 320'h0;
    parameter [319:0] INITVAL_02 = 320'h0;
    parameter [319:0] INITVAL_03 = 320'h0;
    parameter [319:0] INITVAL_04 = 320'h0;
    parameter [319:0] INITVAL_05 = 320'h0;
    parameter [319:0] INITVAL_06 = 320'h0;
    parameter [319:0] INITVAL_07 = 320'h0;
    parameter [319:0] INITVAL_08 = 320'h0;
    parameter [319:0] INITVAL_09 = 320'h0;
    parameter [319:0] INITVAL_0A = 320'h0;
    parameter [319:0] INITVAL_0B = 320'h0;
    parameter [319:0] INITVAL_0C = 320'h0;
    parameter [319:0] INITVAL_0D = 320'h0;
    parameter [319:0] INITVAL_0E = 320'h0;
    parameter [319:0] INITVAL_0F = 320'h0;
    parameter [319:0] INITVAL_10 = 320'h0;
    parameter [319:0] INITVAL_11 = 320'h0;
    parameter [319:0] INITVAL_12 = 320'h0;
    parameter [319:0] INITVAL_13 = 320'h0;
    parameter [319:0] INITVAL_14 = 320'h0;
    parameter [319:0] INITVAL_15 = 320'h0;
    parameter [319:0] INITVAL_16 = 320'h0;
    parameter [319:0] INITVAL_17 = 320'h0;
    parameter [319:0] INITVAL_18 = 320'h0;
    parameter [319:0] INITVAL_19 = 320'h0;
    parameter [319:0] INITVAL_1A = 320'h0;
    parameter [319:0] INITVAL_1B = 320'h0;
    parameter [319:0] INITVAL_1C = 320'h0;
    parameter [319:0] INITVAL_1D = 320'h0;
    parameter [319:0] INITVAL_1E = 320'h0;
    parameter [319:0] INITVAL_1F = 320'h0;
    parameter [319:0] INITVAL_20 = 320'h0;
    parameter [319:0] INITVAL_21 = 320'h0;
    parameter [319:0] INITVAL_22 = 320'h0;
    parameter [319:0] INITVAL_23 = 320'h0;
    parameter [319:0] INITVAL_24 = 320'h0;
    parameter [319:0] INITVAL_25 = 320'h0;
    parameter [319:0] INITVAL_26 = 320'h0;
    parameter [319:0] INITVAL_27 = 320'h0;
    parameter [319:0] INITVAL_28 = 320'h0;
    parameter [319:0] INITVAL_29 = 320'h0;
    parameter [319:0] INITVAL_2A = 320'h0;
    parameter [319:0] INITVAL_2B = 320'h0;
    parameter [319:0] INITVAL_2C = 320'h0;
    parameter [319:0] INITVAL_2D = 320'h0;
    parameter [319:0] INITVAL_2E = 320'h0;
    parameter [319:0] INITVAL_2F = 320'h0;
    parameter [319:0] INITVAL_30 = 320'h0;
    parameter [319:0] INITVAL_31 = 320'h0;
    parameter [319:0] INITVAL_32 = 320'h0;
    parameter [319:0] INITVAL_33 = 320'h0;
    parameter [319:0] INITVAL_34 = 320'h0;
    parameter [319:0] INITVAL_35 = 320'h0;
    parameter [319:0] INITVAL_36 = 320'h0;
    parameter [319:0] INITVAL_37 = 320'h0;
    parameter [319:0] INITVAL_38 = 320'h0;
    parameter [319:0] INITVAL_39 = 320'h0;
    parameter [319:0] INITVAL_3A = 320'h0;
    parameter [319:0] INITVAL_3B = 320'h0;
    parameter [319:0] INITVAL_3C = 320'h0;
    parameter [319:0] INITVAL_3D = 320'h0;
    parameter [319:0] INITVAL_3E = 320'h0;
    parameter [319:0] INITVAL_3F = 320'h0;

    localparam W = DATA_WIDTH_A;
    localparam DEPTH = W == 18 ? 1024 : W == 9 ? 2048 : W == 4 ? 4096 : W == 2 ? 8192 : 16384;
    localparam SHIFT = W == 18 ? 4 : W == 9 ? 3 : W == 4 ? 2 : W == 2 ? 1 : 0;

    // "0bXYZ" -> 3'bXYZ
    function [2:0] csdecode(input [8*5-1:0] s);
        csdecode = {s[23:16] == "1", s[15:8] == "1", s[7:0] == "1"};
    endfunction
    localparam [2:0] CS_A = csdecode(CSDECODE_A);
    localparam [2:0] CS_B = csdecode(CSDECODE_B);

    function is_mode(input [8*16-1:0] s);
        is_mode = s == "NORMAL" || s == "WRITETHROUGH" || s == "READBEFOREWRITE";
    endfunction
    function is_csdecode(input [8*5-1:0] s);
        is_csdecode = s[39:24] == "0b" && (s[23:16] == "0" || s[23:16] == "1") &&
                      (s[15:8] == "0" || s[15:8] == "1") && (s[7:0] == "0" || s[7:0] == "1");
    endfunction

    function [319:0] initval_row(input [5:0] row);
        case (row)
            6'h00: initval_row = INITVAL_00;
            6'h01: initval_row = INITVAL_01;
            6'h02: initval_row = INITVAL_02;
            6'h03: initval_row = INITVAL_03;
            6'h04: initval_row = INITVAL_04;
            6'h05: initval_row = INITVAL_05;
            6'h06: initval_row = INITVAL_06;
            6'h07: initval_row = INITVAL_07;
            6'h08: initval_row = INITVAL_08;
            6'h09: initval_row = INITVAL_09;
            6'h0A: initval_row = INITVAL_0A;
            6'h0B: initval_row = INITVAL_0B;
            6'h0C: initval_row = INITVAL_0C;
            6'h0D: initval_row = INITVAL_0D;
            6'h0E: initval_row = INITVAL_0E;
            6'h0F: initval_row = INITVAL_0F;
            6'h10: initval_row = INITVAL_10;
            6'h11: initval_row = INITVAL_11;
            6'h12: initval_row = INITVAL_12;
            6'h13: initval_row = INITVAL_13;
            6'h14: initval_row = INITVAL_14;
            6'h15: initval_row = INITVAL_15;
            6'h16: initval_row = INITVAL_16;
            6'h17: initval_row = INITVAL_17;
            6'h18: initval_row = INITVAL_18;
            6'h19: initval_row = INITVAL_19;
            6'h1A: initval_row = INITVAL_1A;
            6'h1B: initval_row = INITVAL_1B;
            6'h1C: initval_row = INITVAL_1C;
            6'h1D: initval_row = INITVAL_1D;
            6'h1E: initval_row = INITVAL_1E;
            6'h1F: initval_row = INITVAL_1F;
            6'h20: initval_row = INITVAL_20;
            6'h21: initval_row = INITVAL_21;
            6'h22: initval_row = INITVAL_22;
            6'h23: initval_row = INITVAL_23;
            6'h24: initval_row = INITVAL_24;
            6'h25: initval_row = INITVAL_25;
            6'h26: initval_row = INITVAL_26;
            6'h27: initval_row = INITVAL_27;
            6'h28: initval_row = INITVAL_28;
            6'h29: initval_row = INITVAL_29;
            6'h2A: initval_row = INITVAL_2A;
            6'h2B: initval_row = INITVAL_2B;
            6'h2C: initval_row = INITVAL_2C;
            6'h2D: initval_row = INITVAL_2D;
            6'h2E: initval_row = INITVAL_2E;
            6'h2F: initval_row = INITVAL_2F;
            6'h30: initval_row = INITVAL_30;
            6'h31: initval_row = INITVAL_31;
            6'h32: initval_row = INITVAL_32;
            6'h33: initval_row = INITVAL_33;
            6'h34: initval_row = INITVAL_34;
            6'h35: initval_row = INITVAL_35;
            6'h36: initval_row = INITVAL_36;
            6'h37: initval_row = INITVAL_37;
            6'h38: initval_row = INITVAL_38;
            6'h39: initval_row = INITVAL_39;
            6'h3A: initval_row = INITVAL_3A;
            6'h3B: initval_row = INITVAL_3B;
            6'h3C: initval_row = INITVAL_3C;
            6'h3D: initval_row = INITVAL_3D;
            6'h3E: initval_row = INITVAL_3E;
            6'h3F: initval_row = INITVAL_3F;
            default: initval_row = 320'h0;
        endcase
    endfunction

    reg [W-1:0] mem [0:DEPTH-1];
    integer k;
    initial begin
        if (DATA_WIDTH_A != DATA_WIDTH_B)
            $fatal(1, "DP16KD %m: DATA_WIDTH_A=%0d differs from DATA_WIDTH_B=%0d (mixed widths are not modelled)",
                   DATA_WIDTH_A, DATA_WIDTH_B);
        if (W != 1 && W != 2 && W != 4 && W != 9 && W != 18)
            $fatal(1, "DP16KD %m: DATA_WIDTH %0d is not a DP16KD width (1, 2, 4, 9, 18)", W);
        if (REGMODE_A != "NOREG" && REGMODE_A != "OUTREG")
            $fatal(1, "DP16KD %m: REGMODE_A=%0s is not modelled", REGMODE_A);
        if (REGMODE_B != "NOREG" && REGMODE_B != "OUTREG")
            $fatal(1, "DP16KD %m: REGMODE_B=%0s is not modelled", REGMODE_B);
        if (RESETMODE != "SYNC" && RESETMODE != "ASYNC")
            $fatal(1, "DP16KD %m: RESETMODE=%0s is not modelled", RESETMODE);
        if (ASYNC_RESET_RELEASE != "SYNC" && ASYNC_RESET_RELEASE != "ASYNC")
            $fatal(1, "DP16KD %m: ASYNC_RESET_RELEASE=%0s is not modelled", ASYNC_RESET_RELEASE);
        if (!is_mode(WRITEMODE_A))
            $fatal(1, "DP16KD %m: WRITEMODE_A=%0s is not modelled", WRITEMODE_A);
        if (!is_mode(WRITEMODE_B))
            $fatal(1, "DP16KD %m: WRITEMODE_B=%0s is not modelled", WRITEMODE_B);
        if (!is_csdecode(CSDECODE_A))
            $fatal(1, "DP16KD %m: CSDECODE_A=%0s is not of the form 0bXXX", CSDECODE_A);
        if (!is_csdecode(CSDECODE_B))
            $fatal(1, "DP16KD %m: CSDECODE_B=%0s is not of the form 0bXXX", CSDECODE_B);
        if (GSR != "ENABLED" && GSR != "DISABLED")
            $fatal(1, "DP16KD %m: GSR=%0s is not modelled", GSR);
        if (INIT_DATA != "STATIC")
            $fatal(1, "DP16KD %m: INIT_DATA=%0s is not modelled", INIT_DATA);
        if (CEAMUX != "CEA") $fatal(1, "DP16KD %m: CEAMUX=%0s (an inverted or constant pin) is not modelled", CEAMUX);
        if (OCEAMUX != "OCEA") $fatal(1, "DP16KD %m: OCEAMUX=%0s (an inverted or constant pin) is not modelled", OCEAMUX);
        if (CLKAMUX != "CLKA") $fatal(1, "DP16KD %m: CLKAMUX=%0s (an inverted or constant pin) is not modelled", CLKAMUX);
        if (WEAMUX != "WEA") $fatal(1, "DP16KD %m: WEAMUX=%0s (an inverted or constant pin) is not modelled", WEAMUX);
        if (RSTAMUX != "RSTA") $fatal(1, "DP16KD %m: RSTAMUX=%0s (an inverted or constant pin) is not modelled", RSTAMUX);
        if (CS2AMUX != "CS2A") $fatal(1, "DP16KD %m: CS2AMUX=%0s (an inverted or constant pin) is not modelled", CS2AMUX);
        if (CS1AMUX != "CS1A") $fatal(1, "DP16KD %m: CS1AMUX=%0s (an inverted or constant pin) is not modelled", CS1AMUX);
        if (CS0AMUX != "CS0A") $fatal(1, "DP16KD %m: CS0AMUX=%0s (an inverted or constant pin) is not modelled", CS0AMUX);
        if (CEBMUX != "CEB") $fatal(1, "DP16KD %m: CEBMUX=%0s (an inverted or constant pin) is not modelled", CEBMUX);
        if (OCEBMUX != "OCEB") $fatal(1, "DP16KD %m: OCEBMUX=%0s (an inverted or constant pin) is not modelled", OCEBMUX);
        if (CLKBMUX != "CLKB") $fatal(1, "DP16KD %m: CLKBMUX=%0s (an inverted or constant pin) is not modelled", CLKBMUX);
        if (WEBMUX != "WEB") $fatal(1, "DP16KD %m: WEBMUX=%0s (an inverted or constant pin) is not modelled", WEBMUX);
        if (RSTBMUX != "RSTB") $fatal(1, "DP16KD %m: RSTBMUX=%0s (an inverted or constant pin) is not modelled", RSTBMUX);
        if (CS2BMUX != "CS2B") $fatal(1, "DP16KD %m: CS2BMUX=%0s (an inverted or constant pin) is not modelled", CS2BMUX);
        if (CS1BMUX != "CS1B") $fatal(1, "DP16KD %m: CS1BMUX=%0s (an inverted or constant pin) is not modelled", CS1BMUX);
        if (CS0BMUX != "CS0B") $fatal(1, "DP16KD %m: CS0BMUX=%0s (an inverted or constant pin) is not modelled", CS0BMUX);
        if (W != 18 && (INITVAL_00 | INITVAL_01 | INITVAL_02 | INITVAL_03 | INITVAL_04 | INITVAL_05 | INITVAL_06 | INITVAL_07 | INITVAL_08 | INITVAL_09 | INITVAL_0A | INITVAL_0B | INITVAL_0C | INITVAL_0D | INITVAL_0E | INITVAL_0F | INITVAL_10 | INITVAL_11 | INITVAL_12 | INITVAL_13 | INITVAL_14 | INITVAL_15 | INITVAL_16 | INITVAL_17 | INITVAL_18 | INITVAL_19 | INITVAL_1A | INITVAL_1B | INITVAL_1C | INITVAL_1D | INITVAL_1E | INITVAL_1F | INITVAL_20 | INITVAL_21 | INITVAL_22 | INITVAL_23 | INITVAL_24 | INITVAL_25 | INITVAL_26 | INITVAL_27 | INITVAL_28 | INITVAL_29 | INITVAL_2A | INITVAL_2B | INITVAL_2C | INITVAL_2D | INITVAL_2E | INITVAL_2F | INITVAL_30 | INITVAL_31 | INITVAL_32 | INITVAL_33 | INITVAL_34 | INITVAL_35 | INITVAL_36 | INITVAL_37 | INITVAL_38 | INITVAL_39 | INITVAL_3A | INITVAL_3B | INITVAL_3C | INITVAL_3D | INITVAL_3E | INITVAL_3F) != 320'h0)
            $fatal(1, "DP16KD %m: INITVAL at DATA_WIDTH %0d is not modelled (only x18)", W);
        for (k = 0; k < DEPTH; k = k + 1)
            mem[k] = W == 18 ? initval_row(k[9:4]) >> (20 * k[3:0]) : {W{1'b0}};
    end

    wire [17:0] di_a = {DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4, DIA3, DIA2, DIA1, DIA0};
    wire [17:0] di_b = {DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4, DIB3, DIB2, DIB1, DIB0};
    wire [13:0] ad_a = {ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0};
    wire [13:0] ad_b = {ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0};
    wire [13:0] word_a = ad_a >> SHIFT;
    wire [13:0] word_b = ad_b >> SHIFT;
    wire en_a = CEA && {CSA2, CSA1, CSA0} == CS_A;
    wire en_b = CEB && {CSB2, CSB1, CSB0} == CS_B;
    // bits of the word a write stores: at x18 the byte enables AD[1:0]
    wire [W-1:0] mask_a = W == 18 ? {{9{ad_a[1]}}, {9{ad_a[0]}}} : {W{1'b1}};
    wire [W-1:0] mask_b = W == 18 ? {{9{ad_b[1]}}, {9{ad_b[0]}}} : {W{1'b1}};

    reg [W-1:0] latch_a = {W{1'b0}}, latch_b = {W{1'b0}};
    reg [W-1:0] oreg_a = {W{1'b0}}, oreg_b = {W{1'b0}};

`ifdef RAST_ECP5_SYNC_RESET_UNGATED
    localparam GATED = 0;
`else
    localparam GATED = 1;
`endif
    localparam SYNC = RESETMODE == "SYNC";
    localparam OUTREG_A = REGMODE_A == "OUTREG";
    localparam OUTREG_B = REGMODE_B == "OUTREG";
    // synchronous reset of each port's output stage at this clock edge
    wire srst_a = SYNC && RSTA && (!GATED || (OUTREG_A ? OCEA : CEA));
    wire srst_b = SYNC && RSTB && (!GATED || (OUTREG_B ? OCEB : CEB));
    wire arst_a = !SYNC && RSTA;
    wire arst_b = !SYNC && RSTB;

    // cross-port hazards at one clock edge (both ports on one clock: the other
    // port's clock is high when this one rises)
    wire same_edge = CLKA === 1'b1 && CLKB === 1'b1;
    wire coll_a = same_edge && en_a && !WEA && en_b && WEB && word_a == word_b;   // A reads what B writes
    wire coll_b = same_edge && en_b && !WEB && en_a && WEA && word_a == word_b;   // B reads what A writes
    integer collisions = 0;
    always @(posedge CLKA) begin
        if (same_edge && en_a && en_b && WEA && WEB && word_a == word_b)
            $fatal(1, "DP16KD %m: both ports write word %0d at the same clock edge (t=%0t)", word_a, $time);
        if (coll_a || coll_b) begin
            collisions = collisions + 1;
            if (collisions <= 10)
                $display("DP16KD %m: collision: port %s reads word %0d while port %s writes it at the same clock edge (undefined on the device; read data poisoned), t=%0t",
                         coll_a ? "A" : "B", word_a, coll_a ? "B" : "A", $time);
        end
    end
`ifdef VERILATOR
    wire [W-1:0] poison_a = ~mem[word_a];
    wire [W-1:0] poison_b = ~mem[word_b];
`else
    wire [W-1:0] poison_a = {W{1'bx}};
    wire [W-1:0] poison_b = {W{1'bx}};
`endif

    // port A
    always @(posedge CLKA) begin
        if (en_a && WEA)
            mem[word_a] <= (mem[word_a] & ~mask_a) | (di_a[W-1:0] & mask_a);
    end
    always @(posedge CLKA or posedge arst_a) begin
        if (arst_a) begin
            latch_a <= {W{1'b0}};
            oreg_a <= {W{1'b0}};
        end else begin
            if (OUTREG_A && OCEA) oreg_a <= latch_a;
            if (!OUTREG_A && srst_a) begin
                latch_a <= {W{1'b0}};
            end else if (en_a) begin
                if (!WEA) latch_a <= coll_a ? poison_a : mem[word_a];
                else if (WRITEMODE_A == "WRITETHROUGH") latch_a <= (mem[word_a] & ~mask_a) | (di_a[W-1:0] & mask_a);
                else if (WRITEMODE_A == "READBEFOREWRITE") latch_a <= mem[word_a];
            end
            if (OUTREG_A && srst_a) oreg_a <= {W{1'b0}};
        end
    end

    // port B
    always @(posedge CLKB) begin
        if (en_b && WEB)
            mem[word_b] <= (mem[word_b] & ~mask_b) | (di_b[W-1:0] & mask_b);
    end
    always @(posedge CLKB or posedge arst_b) begin
        if (arst_b) begin
            latch_b <= {W{1'b0}};
            oreg_b <= {W{1'b0}};
        end else begin
            if (OUTREG_B && OCEB) oreg_b <= latch_b;
            if (!OUTREG_B && srst_b) begin
                latch_b <= {W{1'b0}};
            end else if (en_b) begin
                if (!WEB) latch_b <= coll_b ? poison_b : mem[word_b];
                else if (WRITEMODE_B == "WRITETHROUGH") latch_b <= (mem[word_b] & ~mask_b) | (di_b[W-1:0] & mask_b);
                else if (WRITEMODE_B == "READBEFOREWRITE") latch_b <= mem[word_b];
            end
            if (OUTREG_B && srst_b) oreg_b <= {W{1'b0}};
        end
    end

    wire [17:0] do_a = OUTREG_A ? oreg_a : latch_a;
    wire [17:0] do_b = OUTREG_B ? oreg_b : latch_b;
    assign {DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3, DOA2, DOA1, DOA0} = do_a;
    assign {DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3, DOB2, DOB1, DOB0} = do_b;
endmodule
