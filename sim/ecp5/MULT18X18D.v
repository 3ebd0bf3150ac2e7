// MULT18X18D: behavioural simulation model of the ECP5 sysDSP 18x18
// multiplier, written for RAST's netlist cosimulation from Lattice's ECP5
// sysDSP usage guide (TN1267). Yosys's ECP5 library has this cell only as a
// black box; this module is the simulation model.
//
// What is modelled (docs/netlist_sim.md has the readings taken and why):
// * P[35:0] = A * B, each operand 18 bits, signed when its SIGNEDA/SIGNEDB
//   is 1 (two's complement) and unsigned when 0; the 38-bit exact product
//   is cut to its low 36 bits (an 18x18 product of any signedness fits).
// * registers: input A, B, C (REG_INPUTx_CLK), pipeline (REG_PIPELINE_CLK)
//   and output (REG_OUTPUT_CLK), each "NONE" (bypassed) or on CLK0..CLK3,
//   with its own CE0..CE3 and RST0..RST3 selection. SIGNEDA/SIGNEDB travel
//   with their operand (through the operand's input register) and then with
//   the product; SIGNEDP is the product's sign mode (SIGNEDA | SIGNEDB).
// * RESETMODE "SYNC": a register clears at a clock edge with its RST high
//   and its CE high (define RAST_ECP5_SYNC_RESET_UNGATED for the reading
//   without the CE); "ASYNC": at once. Registers power up to 0.
// * ROA/ROB/ROC and SROA/SROB show the operands after their input registers.
//
// Not modelled, refused at time 0 with $fatal: SOURCEB_MODE other than
// "B_SHIFT", HIGHSPEED_CLK other than "NONE", CLKn_DIV other than "ENABLED",
// CAS_MATCH_REG other than "FALSE", MULT_BYPASS other than "DISABLED",
// unknown clock/CE/RST names. SOURCEA or SOURCEB high (the shift inputs
// SRIA/SRIB) stops the simulation when it happens.
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
/* verilator lint_off WIDTHEXPAND */
/* verilator lint_off WIDTHTRUNC */
/* verilator lint_off DECLFILENAME */
module MULT18X18D (
    input A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0,
    input B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0,
    input C17, C16, C15, C14, C13, C12, C11, C10, C9, C8, C7, C6, C5, C4, C3, C2, C1, C0,
    input SIGNEDA, SIGNEDB, SOURCEA, SOURCEB,
    input CLK3, CLK2, CLK1, CLK0, CE3, CE2, CE1, CE0, RST3, RST2, RST1, RST0,
    input SRIA17, SRIA16, SRIA15, SRIA14, SRIA13, SRIA12, SRIA11, SRIA10, SRIA9, SRIA8, SRIA7, SRIA6, SRIA5, SRIA4, SRIA3, SRIA2, SRIA1, SRIA0,
    input SRIB17, SRIB16, SRIB15, SRIB14, SRIB13, SRIB12, SRIB11, SRIB10, SRIB9, SRIB8, SRIB7, SRIB6, SRIB5, SRIB4, SRIB3, SRIB2, SRIB1, SRIB0,
    output SROA17, SROA16, SROA15, SROA14, SROA13, SROA12, SROA11, SROA10, SROA9, SROA8, SROA7, SROA6, SROA5, SROA4, SROA3, SROA2, SROA1, SROA0,
    output SROB17, SROB16, SROB15, SROB14, SROB13, SROB12, SROB11, SROB10, SROB9, SROB8, SROB7, SROB6, SROB5, SROB4, SROB3, SROB2, SROB1, SROB0,
    output ROA17, ROA16, ROA15, ROA14, ROA13, ROA12, ROA11, ROA10, ROA9, ROA8, ROA7, ROA6, ROA5, ROA4, ROA3, ROA2, ROA1, ROA0,
    output ROB17, ROB16, ROB15, ROB14, ROB13, ROB12, ROB11, ROB10, ROB9, ROB8, ROB7, ROB6, ROB5, ROB4, ROB3, ROB2, ROB1, ROB0,
    output ROC17, ROC16, ROC15, ROC14, ROC13, ROC12, ROC11, ROC10, ROC9, ROC8, ROC7, ROC6, ROC5, ROC4, ROC3, ROC2, ROC1, ROC0,
    output P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18, P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0,
    output SIGNEDP
);
    parameter REG_INPUTA_CLK = "NONE";
    parameter REG_INPUTA_CE = "CE0";
    parameter REG_INPUTA_RST = "RST0";
    parameter REG_INPUTB_CLK = "NONE";
    parameter REG_INPUTB_CE = "CE0";
    parameter REG_INPUTB_RST = "RST0";
    parameter REG_INPUTC_CLK = "NONE";
    parameter REG_INPUTC_CE = "CE0";
    parameter REG_INPUTC_RST = "RST0";
    parameter REG_PIPELINE_CLK = "NONE";
    parameter REG_PIPELINE_CE = "CE0";
    parameter REG_PIPELINE_RST = "RST0";
    parameter REG_OUTPUT_CLK = "NONE";
    parameter REG_OUTPUT_CE = "CE0";
    parameter REG_OUTPUT_RST = "RST0";
    parameter CLK0_DIV = "ENABLED";
    parameter CLK1_DIV = "ENABLED";
    parameter CLK2_DIV = "ENABLED";
    parameter CLK3_DIV = "ENABLED";
    parameter HIGHSPEED_CLK = "NONE";
    parameter GSR = "ENABLED";
    parameter CAS_MATCH_REG = "FALSE";
    parameter SOURCEB_MODE = "B_SHIFT";
    parameter MULT_BYPASS = "DISABLED";
    parameter RESETMODE = "SYNC";

    function is_clk(input [8*8-1:0] s);
        is_clk = s == "NONE" || s == "CLK0" || s == "CLK1" || s == "CLK2" || s == "CLK3";
    endfunction
    function is_ce(input [8*8-1:0] s);
        is_ce = s == "CE0" || s == "CE1" || s == "CE2" || s == "CE3";
    endfunction
    function is_rst(input [8*8-1:0] s);
        is_rst = s == "RST0" || s == "RST1" || s == "RST2" || s == "RST3";
    endfunction

    initial begin
        if (!is_clk(REG_INPUTA_CLK) || !is_clk(REG_INPUTB_CLK) || !is_clk(REG_INPUTC_CLK) ||
            !is_clk(REG_PIPELINE_CLK) || !is_clk(REG_OUTPUT_CLK))
            $fatal(1, "MULT18X18D %m: a REG_*_CLK is not NONE or CLK0..CLK3");
        if (!is_ce(REG_INPUTA_CE) || !is_ce(REG_INPUTB_CE) || !is_ce(REG_INPUTC_CE) ||
            !is_ce(REG_PIPELINE_CE) || !is_ce(REG_OUTPUT_CE))
            $fatal(1, "MULT18X18D %m: a REG_*_CE is not CE0..CE3");
        if (!is_rst(REG_INPUTA_RST) || !is_rst(REG_INPUTB_RST) || !is_rst(REG_INPUTC_RST) ||
            !is_rst(REG_PIPELINE_RST) || !is_rst(REG_OUTPUT_RST))
            $fatal(1, "MULT18X18D %m: a REG_*_RST is not RST0..RST3");
        if (CLK0_DIV != "ENABLED" || CLK1_DIV != "ENABLED" || CLK2_DIV != "ENABLED" || CLK3_DIV != "ENABLED")
            $fatal(1, "MULT18X18D %m: CLKn_DIV other than ENABLED is not modelled");
        if (HIGHSPEED_CLK != "NONE")
            $fatal(1, "MULT18X18D %m: HIGHSPEED_CLK=%0s is not modelled", HIGHSPEED_CLK);
        if (CAS_MATCH_REG != "FALSE")
            $fatal(1, "MULT18X18D %m: CAS_MATCH_REG=%0s is not modelled", CAS_MATCH_REG);
        if (SOURCEB_MODE != "B_SHIFT")
            $fatal(1, "MULT18X18D %m: SOURCEB_MODE=%0s is not modelled", SOURCEB_MODE);
        if (MULT_BYPASS != "DISABLED")
            $fatal(1, "MULT18X18D %m: MULT_BYPASS=%0s is not modelled", MULT_BYPASS);
        if (RESETMODE != "SYNC" && RESETMODE != "ASYNC")
            $fatal(1, "MULT18X18D %m: RESETMODE=%0s is not modelled", RESETMODE);
        if (GSR != "ENABLED" && GSR != "DISABLED")
            $fatal(1, "MULT18X18D %m: GSR=%0s is not modelled", GSR);
    end
    always @(*) begin
        if (SOURCEA === 1'b1 || SOURCEB === 1'b1)
            $fatal(1, "MULT18X18D %m: SOURCEA/SOURCEB high (shift-register operands) is not modelled");
    end

    wire [3:0] clks = {CLK3, CLK2, CLK1, CLK0};
    wire [3:0] ces = {CE3, CE2, CE1, CE0};
    wire [3:0] rsts = {RST3, RST2, RST1, RST0};
    wire [18:0] a_in = {SIGNEDA, A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0};
    wire [18:0] b_in = {SIGNEDB, B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0};
    wire [17:0] c_in = {C17, C16, C15, C14, C13, C12, C11, C10, C9, C8, C7, C6, C5, C4, C3, C2, C1, C0};
    wire [18:0] a_q, b_q;   // {sign mode, operand} after the input registers
    wire [17:0] c_q;
    wire [36:0] m_in, m_q, p_q;   // {SIGNEDP, product}

    RAST_MULT18X18D_REG #(.WIDTH(19), .CLK(REG_INPUTA_CLK), .CE(REG_INPUTA_CE), .RST(REG_INPUTA_RST), .RESETMODE(RESETMODE))
        reg_a (.clks(clks), .ces(ces), .rsts(rsts), .d(a_in), .q(a_q));
    RAST_MULT18X18D_REG #(.WIDTH(19), .CLK(REG_INPUTB_CLK), .CE(REG_INPUTB_CE), .RST(REG_INPUTB_RST), .RESETMODE(RESETMODE))
        reg_b (.clks(clks), .ces(ces), .rsts(rsts), .d(b_in), .q(b_q));
    RAST_MULT18X18D_REG #(.WIDTH(18), .CLK(REG_INPUTC_CLK), .CE(REG_INPUTC_CE), .RST(REG_INPUTC_RST), .RESETMODE(RESETMODE))
        reg_c (.clks(clks), .ces(ces), .rsts(rsts), .d(c_in), .q(c_q));

    wire signed [18:0] a_ext = {a_q[18] & a_q[17], a_q[17:0]};
    wire signed [18:0] b_ext = {b_q[18] & b_q[17], b_q[17:0]};
    wire signed [37:0] product = a_ext * b_ext;
    assign m_in = {a_q[18] | b_q[18], product[35:0]};

    RAST_MULT18X18D_REG #(.WIDTH(37), .CLK(REG_PIPELINE_CLK), .CE(REG_PIPELINE_CE), .RST(REG_PIPELINE_RST), .RESETMODE(RESETMODE))
        reg_pipe (.clks(clks), .ces(ces), .rsts(rsts), .d(m_in), .q(m_q));
    RAST_MULT18X18D_REG #(.WIDTH(37), .CLK(REG_OUTPUT_CLK), .CE(REG_OUTPUT_CE), .RST(REG_OUTPUT_RST), .RESETMODE(RESETMODE))
        reg_out (.clks(clks), .ces(ces), .rsts(rsts), .d(m_q), .q(p_q));

    assign {P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18, P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0} = p_q[35:0];
    assign SIGNEDP = p_q[36];
    assign {ROA17, ROA16, ROA15, ROA14, ROA13, ROA12, ROA11, ROA10, ROA9, ROA8, ROA7, ROA6, ROA5, ROA4, ROA3, ROA2, ROA1, ROA0} = a_q[17:0];
    assign {ROB17, ROB16, ROB15, ROB14, ROB13, ROB12, ROB11, ROB10, ROB9, ROB8, ROB7, ROB6, ROB5, ROB4, ROB3, ROB2, ROB1, ROB0} = b_q[17:0];
    assign {ROC17, ROC16, ROC15, ROC14, ROC13, ROC12, ROC11, ROC10, ROC9, ROC8, ROC7, ROC6, ROC5, ROC4, ROC3, ROC2, ROC1, ROC0} = c_q;
    assign {SROA17, SROA16, SROA15, SROA14, SROA13, SROA12, SROA11, SROA10, SROA9, SROA8, SROA7, SROA6, SROA5, SROA4, SROA3, SROA2, SROA1, SROA0} = a_q[17:0];
    assign {SROB17, SROB16, SROB15, SROB14, SROB13, SROB12, SROB11, SROB10, SROB9, SROB8, SROB7, SROB6, SROB5, SROB4, SROB3, SROB2, SROB1, SROB0} = b_q[17:0];
endmodule

// One register of the MULT18X18D: bypassed (CLK "NONE") or clocked by the
// selected CLKn, enabled by CEn, cleared by RSTn (SYNC: gated by CEn unless
// RAST_ECP5_SYNC_RESET_UNGATED; ASYNC: at once). Powers up to 0.
module RAST_MULT18X18D_REG #(
    parameter WIDTH = 18,
    parameter CLK = "NONE",
    parameter CE = "CE0",
    parameter RST = "RST0",
    parameter RESETMODE = "SYNC"
) (
    input [3:0] clks, ces, rsts,
    input [WIDTH-1:0] d,
    output [WIDTH-1:0] q
);
    localparam [1:0] NC = CLK[7:0] - "0";
    localparam [1:0] NE = CE[7:0] - "0";
    localparam [1:0] NR = RST[7:0] - "0";
`ifdef RAST_ECP5_SYNC_RESET_UNGATED
    localparam GATED = 0;
`else
    localparam GATED = 1;
`endif
    generate
        if (CLK == "NONE") begin : bypass
            assign q = d;
        end else begin : clocked
            reg [WIDTH-1:0] r = {WIDTH{1'b0}};
            wire clk = clks[NC];
            wire ce = ces[NE];
            wire rst = rsts[NR];
            if (RESETMODE == "ASYNC") begin : arst
                always @(posedge clk or posedge rst)
                    if (rst) r <= {WIDTH{1'b0}};
                    else if (ce) r <= d;
            end else begin : srst
                always @(posedge clk)
                    if (rst && (ce || !GATED)) r <= {WIDTH{1'b0}};
                    else if (ce) r <= d;
            end
            assign q = r;
        end
    endgenerate
endmodule
