// Unit-test top of the ECP5 primitive models (sim/ecp5/DP16KD.v, MULT18X18D.v):
// a few instances in the modes the build uses, their pins gathered into
// vectors for the cocotb tests in rast.sim.tb_ecp5 (tests/test_ecp5_models.py).
/* verilator lint_off DECLFILENAME */
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off PINCONNECTEMPTY */
/* verilator lint_off MULTITOP */
/* verilator lint_off PINMISSING */
module dp16kd_pins #(
    parameter DATA_WIDTH = 18,
    parameter REGMODE_A = "NOREG",
    parameter REGMODE_B = "NOREG",
    parameter WRITEMODE_A = "NORMAL",
    parameter CSDECODE_B = "0b000",
    parameter [319:0] INITVAL_00 = 320'h0,
    parameter [319:0] INITVAL_01 = 320'h0
) (
    input clk,
    input [17:0] dia, input [13:0] ada, input cea, input ocea, input wea, input rsta, input [2:0] csa,
    output [17:0] doa,
    input [17:0] dib, input [13:0] adb, input ceb, input oceb, input web, input rstb, input [2:0] csb,
    output [17:0] dob
);
    DP16KD #(.DATA_WIDTH_A(DATA_WIDTH), .DATA_WIDTH_B(DATA_WIDTH), .REGMODE_A(REGMODE_A),
             .REGMODE_B(REGMODE_B), .WRITEMODE_A(WRITEMODE_A), .CSDECODE_B(CSDECODE_B),
             .RESETMODE("SYNC"), .GSR("DISABLED"), .INITVAL_00(INITVAL_00), .INITVAL_01(INITVAL_01)) ram (
        .DIA0(dia[0]), .DIA1(dia[1]), .DIA2(dia[2]), .DIA3(dia[3]), .DIA4(dia[4]), .DIA5(dia[5]), .DIA6(dia[6]), .DIA7(dia[7]), .DIA8(dia[8]), .DIA9(dia[9]), .DIA10(dia[10]), .DIA11(dia[11]), .DIA12(dia[12]), .DIA13(dia[13]), .DIA14(dia[14]), .DIA15(dia[15]), .DIA16(dia[16]), .DIA17(dia[17]),
        .ADA0(ada[0]), .ADA1(ada[1]), .ADA2(ada[2]), .ADA3(ada[3]), .ADA4(ada[4]), .ADA5(ada[5]), .ADA6(ada[6]), .ADA7(ada[7]), .ADA8(ada[8]), .ADA9(ada[9]), .ADA10(ada[10]), .ADA11(ada[11]), .ADA12(ada[12]), .ADA13(ada[13]),
        .DOA0(doa[0]), .DOA1(doa[1]), .DOA2(doa[2]), .DOA3(doa[3]), .DOA4(doa[4]), .DOA5(doa[5]), .DOA6(doa[6]), .DOA7(doa[7]), .DOA8(doa[8]), .DOA9(doa[9]), .DOA10(doa[10]), .DOA11(doa[11]), .DOA12(doa[12]), .DOA13(doa[13]), .DOA14(doa[14]), .DOA15(doa[15]), .DOA16(doa[16]), .DOA17(doa[17]),
        .CEA(cea), .OCEA(ocea), .CLKA(clk), .WEA(wea), .RSTA(rsta), .CSA2(csa[2]), .CSA1(csa[1]), .CSA0(csa[0]),
        .DIB0(dib[0]), .DIB1(dib[1]), .DIB2(dib[2]), .DIB3(dib[3]), .DIB4(dib[4]), .DIB5(dib[5]), .DIB6(dib[6]), .DIB7(dib[7]), .DIB8(dib[8]), .DIB9(dib[9]), .DIB10(dib[10]), .DIB11(dib[11]), .DIB12(dib[12]), .DIB13(dib[13]), .DIB14(dib[14]), .DIB15(dib[15]), .DIB16(dib[16]), .DIB17(dib[17]),
        .ADB0(adb[0]), .ADB1(adb[1]), .ADB2(adb[2]), .ADB3(adb[3]), .ADB4(adb[4]), .ADB5(adb[5]), .ADB6(adb[6]), .ADB7(adb[7]), .ADB8(adb[8]), .ADB9(adb[9]), .ADB10(adb[10]), .ADB11(adb[11]), .ADB12(adb[12]), .ADB13(adb[13]),
        .DOB0(dob[0]), .DOB1(dob[1]), .DOB2(dob[2]), .DOB3(dob[3]), .DOB4(dob[4]), .DOB5(dob[5]), .DOB6(dob[6]), .DOB7(dob[7]), .DOB8(dob[8]), .DOB9(dob[9]), .DOB10(dob[10]), .DOB11(dob[11]), .DOB12(dob[12]), .DOB13(dob[13]), .DOB14(dob[14]), .DOB15(dob[15]), .DOB16(dob[16]), .DOB17(dob[17]),
        .CEB(ceb), .OCEB(oceb), .CLKB(clk), .WEB(web), .RSTB(rstb), .CSB2(csb[2]), .CSB1(csb[1]), .CSB0(csb[0])
    );
endmodule

module mult_pins #(
    parameter INPUT_CLK = "NONE",
    parameter OUTPUT_CLK = "NONE"
) (
    input clk, input ce, input rst, input signeda, input signedb,
    input [17:0] a, input [17:0] b, output [35:0] p
);
    MULT18X18D #(.REG_INPUTA_CLK(INPUT_CLK), .REG_INPUTB_CLK(INPUT_CLK), .REG_OUTPUT_CLK(OUTPUT_CLK),
                 .RESETMODE("SYNC"), .GSR("DISABLED")) mult (
        .A0(a[0]), .A1(a[1]), .A2(a[2]), .A3(a[3]), .A4(a[4]), .A5(a[5]), .A6(a[6]), .A7(a[7]), .A8(a[8]), .A9(a[9]), .A10(a[10]), .A11(a[11]), .A12(a[12]), .A13(a[13]), .A14(a[14]), .A15(a[15]), .A16(a[16]), .A17(a[17]),
        .B0(b[0]), .B1(b[1]), .B2(b[2]), .B3(b[3]), .B4(b[4]), .B5(b[5]), .B6(b[6]), .B7(b[7]), .B8(b[8]), .B9(b[9]), .B10(b[10]), .B11(b[11]), .B12(b[12]), .B13(b[13]), .B14(b[14]), .B15(b[15]), .B16(b[16]), .B17(b[17]),
        .P0(p[0]), .P1(p[1]), .P2(p[2]), .P3(p[3]), .P4(p[4]), .P5(p[5]), .P6(p[6]), .P7(p[7]), .P8(p[8]), .P9(p[9]), .P10(p[10]), .P11(p[11]), .P12(p[12]), .P13(p[13]), .P14(p[14]), .P15(p[15]), .P16(p[16]), .P17(p[17]), .P18(p[18]), .P19(p[19]), .P20(p[20]), .P21(p[21]), .P22(p[22]), .P23(p[23]), .P24(p[24]), .P25(p[25]), .P26(p[26]), .P27(p[27]), .P28(p[28]), .P29(p[29]), .P30(p[30]), .P31(p[31]), .P32(p[32]), .P33(p[33]), .P34(p[34]), .P35(p[35]),
        .SIGNEDA(signeda), .SIGNEDB(signedb), .SOURCEA(1'b0), .SOURCEB(1'b0),
        .CLK0(clk), .CE0(ce), .RST0(rst), .CLK1(1'b0), .CLK2(1'b0), .CLK3(1'b0),
        .CE1(1'b0), .CE2(1'b0), .CE3(1'b0), .RST1(1'b0), .RST2(1'b0), .RST3(1'b0)
    );
endmodule

module ecp5_models_tb (input clk);
    // x18, port B with its output register (the width-sliced RAMs' mode)
    dp16kd_pins #(.DATA_WIDTH(18), .REGMODE_B("OUTREG")) x18_outreg (.clk(clk));
    // x2 without output register, port B selected by CS = 3'b101
    dp16kd_pins #(.DATA_WIDTH(2), .CSDECODE_B("0b101")) x2_cs (.clk(clk));
    // x18 with power-up contents and a write-through port A (the inferred ROM's width)
    dp16kd_pins #(.DATA_WIDTH(18), .WRITEMODE_A("WRITETHROUGH"),
                  .INITVAL_00({{14{20'h0}}, 20'h3ffff, 20'h00001}),
                  .INITVAL_01({{14{20'h0}}, 20'h12345, 20'h0})) x18_init (.clk(clk));
    // input and output registers (the build's multipliers), and one with none
    mult_pins #(.INPUT_CLK("CLK0"), .OUTPUT_CLK("CLK0")) mult_regs (.clk(clk));
    mult_pins #(.INPUT_CLK("NONE"), .OUTPUT_CLK("NONE")) mult_comb (.clk(clk));
endmodule

// A DP16KD in a mode the model does not implement (mixed widths): must stop at time 0.
module ecp5_unmodelled_dp16kd (input clk);
    DP16KD #(.DATA_WIDTH_A(9), .DATA_WIDTH_B(18)) ram (.CLKA(clk), .CLKB(clk));
endmodule

// A MULT18X18D in a mode the model does not implement: must stop at time 0.
module ecp5_unmodelled_mult (input clk);
    MULT18X18D #(.HIGHSPEED_CLK("CLK0")) mult (.CLK0(clk));
endmodule
