"""Board top, clocking and the bitstream flow.

The fast tests elaborate the ULX3S top and check the PLL and pin map; the
slow one builds one pipeline of the engine on the ULX3S-85F with Yosys,
nextpnr and ecppack and checks its report.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from rast.gateware.build import BuildConfig, build, parse_yosys_stat
from rast.gateware.platforms import make_platform, pin_table
from rast.gateware.pll import pll_params
from rast.gateware.uart import divisor


def test_pll_settings():
    p = pll_params(25, 100)
    assert (p.refclk_div, p.feedback_div, p.output_div, p.f_out_mhz) == (1, 4, 6, 100)
    assert 400 <= p.f_vco_mhz <= 800
    assert pll_params(25, 200).f_out_mhz == 200
    assert abs(pll_params(25, 133.3, tolerance_mhz=0.2).f_out_mhz - 133.3) < 0.2
    with pytest.raises(ValueError, match=r"^PLL output frequency must be in \[3.125, 400.0\] MHz, not 500$"):
        pll_params(25, 500)


def test_uart_divisor():
    assert divisor(100e6, 1_000_000) == 100
    with pytest.raises(ValueError, match=r"too fast"):
        divisor(10e6, 3_000_000)


def test_pin_map_uses_distinct_header_pins():
    rows = pin_table()
    balls = [b for _, _, b in rows]
    assert len(rows) == 16 + 1 + 16 + 1 + 1 + 2          # ..., the ACP and ARP inputs
    assert len(set(balls)) == len(balls)


def test_plain_device_needs_pinmap_for_other_packages():
    with pytest.raises(ValueError, match=r"^Package BG256 needs a pin map"):
        make_platform(None, device="LFE5U-25F", package="BG256", speed=6)
    assert make_platform(None, device="LFE5U-85F", package="BG381", speed="6").device == "LFE5U-85F"


@pytest.mark.parametrize("board,device", [("ulx3s-85f", None), (None, "LFE5U-45F")])
def test_elaborates_for_ecp5(tmp_path, board, device):
    """Platform files (RTLIL, LPF) are produced; the sample interface is DDR on the header."""
    cfg = BuildConfig(board=board, device=device, package="BG381", speed="8", channels=2,
                      pool_words=256, max_delay=254, max_tap=62, clock_mhz=200)
    rep = build(cfg, tmp_path, quiet=True, run_tools=False)
    il = (tmp_path / "rast_top.il").read_text()
    lpf = (tmp_path / "rast_top.lpf").read_text()
    assert il.count("cell \\IDDRX1F") == 16 and il.count("cell \\ODDRX1F") == 16 + 3
    assert "cell \\EHXPLLL" in il
    # the core's reset on a global network: a DCCA drives it
    dcca = re.search(r"cell \\DCCA \S+\n(.*?)\n  end", il, re.S).group(1)
    assert re.search(r"connect \\CLKO \\rst$", dcca, re.M), dcca
    # one pipeline of 10 slots serves both channels: 4 complex + 2 gain + the
    # FIR's 2 MAC and 2 linear-step multipliers
    assert il.count("cell \\MULT18X18D") == 10
    assert 'LOCATE COMP "rts_adc_0__data__io[0]" SITE "B11"' in lpf
    assert rep["pll"]["f_out_mhz"] == 200.0 and rep["build"]["sample_rate_hz"] == 20_000_000
    assert rep["build"]["slots"] == 10 and rep["config"]["pipelines"] == 1
    assert rep["memory"]["pool_words"] == 256


def test_yosys_stat_parser():
    log = """
Printing statistics.

=== rast_top ===

   Number of cells:              10
     DP16KD                         2
     LUT4                         100
     MULT18X18D                     4
"""
    assert parse_yosys_stat(log) == {"DP16KD": 2, "LUT4": 100, "MULT18X18D": 4}


#: The slow build: one pipeline of the engine (4 channels, M = 4 slots) on
#: the full board top at a 100 MHz fabric clock and 25 MS/s, with the default
#: build's delays (8190 + 2046 samples) and a 4,096-word pool: the default
#: build's structure at a size and clock CI's two cores route in a minute
#: (docs/bitstream.md has the 200 MHz and 64-channel rungs, measured by
#: bench/bench_bitstream.py).
CI_BUILD = ["--channels", "4", "--sample-rate-mhz", "25", "--clock-mhz", "100", "--pool-words", "4096"]


@pytest.mark.slow
def test_engine_bitstream(tmp_path):
    """`rast build` of one time-multiplexed pipeline meets timing and reports
    what it replays."""
    out = tmp_path / "bit"
    proc = subprocess.run([sys.executable, "-m", "rast.cli", "build", *CI_BUILD, "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    rep = json.loads((out / "report.json").read_text())
    assert (out / "rast_top.bit").stat().st_size > 100_000
    assert rep["timing"]["met"] is True and rep["timing"]["fmax_mhz"] >= 100.0
    assert rep["config"]["channels"] == 4 and rep["config"]["pipelines"] == 1
    assert rep["build"]["sample_rate_hz"] == 25_000_000 and rep["build"]["slots"] == 4
    assert rep["build"]["interpolation"] == "fir"
    r = rep["resources"]
    assert r["dsps"]["used"] == 10 and r["dsps"]["available"] == 156
    assert r["block_rams"]["used"] <= r["block_rams"]["available"] == 208
    assert 0 < r["luts"]["used"] < r["luts"]["available"]
    assert 0 < r["ffs"]["used"] < r["ffs"]["available"]
    assert rep["memory"]["pool_words"] == 4096
    assert rep["memory"]["delay_samples"] == {"common": 8190, "tap": 2046}
    assert "clock" in proc.stdout and "met" in proc.stdout


# ---- the SDRAM build (`rast build --sdram`) ----------------------------------------------------

def test_pll_secondary_outputs_phase():
    """Secondary outputs from the EHXPLLL formulas, worked out by hand:
    f_out = 25 MHz x CLKFB_DIV / CLKI_DIV, VCO = f_out x CLKOP_DIV; an output
    of divider D is VCO / D and at 0° with CPHASE = D - 1 (CLKOP's setting),
    each CPHASE step a VCO period (360° / D), each FPHASE step an eighth."""
    from rast.gateware.pll import PLLOutput
    # 100 MHz fabric: VCO 600 MHz (CLKOP_DIV 6); 50 MHz is 600 / 12; 90° of
    # 20 ns is 5 ns = 3 VCO periods of 1.667 ns: CPHASE 11 + 3, FPHASE 0.
    p = pll_params(25, 100, outputs=[("sdram", 50), ("sdram_ps", 50, 90)])
    assert (p.refclk_div, p.feedback_div, p.output_div, p.f_vco_mhz) == (1, 4, 6, 600)
    assert p.outputs == (PLLOutput("CLKOS", "sdram", 50.0, 12, 11, 0),
                         PLLOutput("CLKOS2", "sdram_ps", 50.0, 12, 14, 0))
    assert p.outputs[1].phase_deg == 90.0
    # 200 MHz fabric: VCO 600 (CLKOP_DIV 3), the same SDRAM outputs.
    p = pll_params(25, 200, outputs=[("sdram", 50), ("sdram_ps", 50, 90)])
    assert (p.output_div, p.f_vco_mhz) == (3, 600)
    assert [(o.div, o.cphase, o.fphase) for o in p.outputs] == [(12, 11, 0), (12, 14, 0)]
    # 22.5° at 50 MHz: 0.75 VCO period = 6 eighths; 180°: 6 periods.
    p = pll_params(25, 100, outputs=[("a", 50, 22.5), ("b", 50, 180)])
    assert [(o.cphase, o.fphase) for o in p.outputs] == [(11, 6), (17, 0)]
    # 75 MHz beside 100 MHz: the VCO must be a common multiple, 600 (600 / 8).
    p = pll_params(25, 100, outputs=[("x", 75)])
    assert (p.f_vco_mhz, p.outputs[0].div, p.outputs[0].f_out_mhz) == (600, 8, 75.0)
    # no outputs: the single-output PLL as before
    assert pll_params(25, 100).outputs == ()


def test_pll_output_errors():
    from rast.gateware.pll import ECP5PLL
    with pytest.raises(ValueError, match=r"^The ECP5 PLL has 3 secondary outputs \(CLKOS, CLKOS2, CLKOS3\); "
                                         r"4 were asked$"):
        pll_params(25, 100, outputs=[("a", 50), ("b", 50), ("c", 50), ("d", 50)])
    with pytest.raises(ValueError, match=r"^PLL output domain 'a' is given twice$"):
        pll_params(25, 100, outputs=[("a", 50), ("a", 25)])
    with pytest.raises(ValueError, match=r"^PLL output 'a': phase must be a number of degrees in "
                                         r"\[0, 360\), not 360$"):
        pll_params(25, 100, outputs=[("a", 50, 360)])
    with pytest.raises(ValueError, match=r"^PLL output 'a': frequency must be in \[3.125, 400.0\] MHz, not 500$"):
        pll_params(25, 100, outputs=[("a", 500)])
    # 190 MHz needs a VCO of 570 or 760 MHz: no whole divider gives 50 MHz
    with pytest.raises(ValueError, match=r"^The ECP5 PLL cannot make 190 MHz and sdram: 50 MHz from 25 MHz"):
        pll_params(25, 190, outputs=[("sdram", 50)])
    p = pll_params(25, 100, outputs=[("sync", 50)])
    with pytest.raises(ValueError, match=r"^PLL domains must differ: sync, sync$"):
        ECP5PLL(None, p, domain="sync")


def test_build_config_pool():
    from rast.gateware.build import check
    from rast.model.contract.fixedpoint import SDRAM_MAX_POOL_WORDS
    assert BuildConfig().pool == "bram" and BuildConfig().pool_words == 65536
    assert BuildConfig(pool="sdram").pool_words == SDRAM_MAX_POOL_WORDS == 1 << 23
    assert BuildConfig(pool="sdram", pool_words=1 << 20).pool_words == 1 << 20
    assert BuildConfig(pool="sdram").replay_kwargs()["pool"] == "sdram"
    with pytest.raises(ValueError, match=r"^Build pool must be one of bram, sdram, not 'dram'$"):
        BuildConfig(pool="dram")
    with pytest.raises(ValueError, match=r"^A stream pool in SDRAM needs a board with SDRAM \(a ULX3S\); the "
                                         r"plain device LFE5U-85F has none$"):
        check(BuildConfig(board=None, device="LFE5U-85F", package="BG381", speed="6", pool="sdram"))
    with pytest.raises(ValueError, match=r"^Pool words of an SDRAM pool must be a power of two"):
        check(BuildConfig(pool="sdram", pool_words=81920))
    with pytest.raises(ValueError, match=r"^The ECP5 PLL cannot make 190 MHz and sdram: 50 MHz"):
        check(BuildConfig(pool="sdram", channels=10, sample_rate_mhz=19, clock_mhz=190))
    # the pool's block RAMs are not counted for an SDRAM pool: 64 channels with
    # the whole SDRAM pass the device check
    contract, _ = check(BuildConfig(pool="sdram"))
    assert contract.pool == "sdram" and contract.pool_words == 1 << 23


def _rtlil_module(il, name):
    start = il.index(f"module {name}\n")
    return il[start:il.index("\nend\n", start)]


def test_sdram_board_top_elaborates(tmp_path):
    """The SDRAM board top: LiteDRAM's core on the ULX3S's sdram pins (data
    pads raw), the SDRAM clock at F19 from an ODDRX1F with D0 = 1, D1 = 0 on
    the 90° PLL output, the ESP32's GPIO0 high, the core's Verilog beside the
    design, both clocks and the SDRAM's words in the report."""
    cfg = BuildConfig(channels=10, sample_rate_mhz=10, clock_mhz=100, pool="sdram")
    rep = build(cfg, tmp_path, quiet=True, run_tools=False)
    il = (tmp_path / "rast_top.il").read_text()
    lpf = (tmp_path / "rast_top.lpf").read_text()
    assert "module litedram_core" in (tmp_path / "litedram_core.v").read_text()
    assert "read_verilog  litedram_core.v" in (tmp_path / "rast_top.ys").read_text()

    # every SDRAM pin placed: clk, cke, cs, we, ras, cas, ba (2), a (13), dq (16), dqm (2)
    assert len(re.findall(r'LOCATE COMP "sdram_0__\w+__io(\[\d+\])?" SITE', lpf)) == 39
    assert 'LOCATE COMP "sdram_0__clk__io" SITE "F19"' in lpf
    assert 'LOCATE COMP "sdram_0__dq__io[0]" SITE "J16"' in lpf
    assert 'LOCATE COMP "wifi_gpio0_0__io" SITE "L2"' in lpf

    # the core: one instance, its dq on the raw pads (no buffer of the platform's between)
    core = re.findall(r"cell \\litedram_core \S+\n(.*?)\n  end", il, re.S)
    assert len(core) == 1
    assert re.search(r"connect \\sdram_dq \\sdram_0__dq__io \[15:0\]", core[0])
    assert not re.search(r"cell \\(BB|IB|OBZ) .*\n(.*\n){0,3}.*sdram_0__dq__io", il)

    # the PLL: CLKOP 100 MHz (VCO 600), CLKOS 50 MHz, CLKOS2 50 MHz at +90° (CPHASE 11 + 3)
    pll = re.search(r"cell \\EHXPLLL \S+\n(.*?)\n  end", il, re.S).group(1)
    for k, v in (("CLKOP_DIV", 6), ("CLKOS_DIV", 12), ("CLKOS_CPHASE", 11), ("CLKOS2_DIV", 12),
                 ("CLKOS2_CPHASE", 14), ("CLKOS2_FPHASE", 0)):
        assert re.search(rf"parameter \\{k} {v}\n", pll), k
    ps_clk = re.search(r"connect \\CLKOS2 (\\\S+)", pll).group(1)

    # the SDRAM clock pin: the one module with an ODDRX1F driving sdram_0__clk__io,
    # clocked by CLKOS2, its two data bits 1 (first half) and 0 from the top
    mods = [m for m in re.findall(r"\nmodule (\S+)\n", il)
            if "cell \\ODDRX1F" in _rtlil_module(il, m)
            and "sdram_0__clk__io" in _rtlil_module(il, m)]
    assert len(mods) == 1
    body = _rtlil_module(il, mods[0])
    assert body.count("cell \\ODDRX1F") == 1
    assert re.search(rf"connect \\SCLK {re.escape(ps_clk)} \[0\]", body)
    inst = re.search(rf"cell {re.escape(mods[0])} \S+\n(.*?)\n  end", il, re.S).group(1)
    data = re.search(r"connect \\o (\\\S+) \[1:0\]", inst).group(1)
    assert f"assign {data} [0] 1'1" in il and f"assign {data} [1] 1'0" in il

    assert rep["config"]["pool"] == "sdram" and rep["build"]["pool"] == "sdram"
    assert rep["memory"]["pool_words"] == rep["memory"]["sdram_words"] == 1 << 23
    assert [(o["domain"], o["f_out_mhz"], o["phase_deg"]) for o in rep["pll"]["outputs"]] == \
        [("sdram", 50.0, 0.0), ("sdram_ps", 50.0, 90.0)]


def test_bram_board_top_unchanged(tmp_path):
    """A block-RAM build has no SDRAM pins, one PLL output and no LiteDRAM."""
    rep = build(BuildConfig(channels=2, pool_words=256, max_delay=254, max_tap=62), tmp_path,
                quiet=True, run_tools=False)
    il = (tmp_path / "rast_top.il").read_text()
    lpf = (tmp_path / "rast_top.lpf").read_text()
    assert "sdram_0__" not in lpf and "wifi_gpio0" not in lpf and "litedram_core" not in il
    assert "CLKOS_ENABLE" not in il and "outputs" not in rep["pll"]
    assert not (tmp_path / "litedram_core.v").exists()


def test_clock_domains_from_nextpnr_report():
    """The domains' clocks found in nextpnr's report (clocks named after nets):
    by constraint, then by the net's name, then by the cells on the worst
    path (LiteDRAM's core is the submodule ``sdram``)."""
    from rast.gateware.build import clock_domains

    def path(clk, cell):
        return {"from": f"posedge {clk}", "to": f"posedge {clk}",
                "path": [{"type": "clk-to-q", "delay": 1.0, "from": {"cell": cell}, "to": {"cell": cell}}]}
    # as nextpnr named them in the SDRAM build (seed 1)
    clocks = {"$glbnet$pll.sdram_ps_clk": {"achieved_mhz": 630.9, "constraint_mhz": 50.0},
              "$glbnet$core.sdram_clk": {"achieved_mhz": 74.8, "constraint_mhz": 50.0},
              "$glbnet$core.clk": {"achieved_mhz": 92.9, "constraint_mhz": 100.0}}
    assert clock_domains(clocks, {}, 100.0, 50.0) == {
        "sync": "$glbnet$core.clk", "sdram": "$glbnet$core.sdram_clk", "sdram_ps": "$glbnet$pll.sdram_ps_clk"}
    assert clock_domains(clocks, {}, 100.0) == {"sync": "$glbnet$core.clk"}
    # both at 50 MHz and named after other nets: the worst paths decide
    clocks = {"$glbnet$a": {"achieved_mhz": 80.0, "constraint_mhz": 50.0},
              "$glbnet$b": {"achieved_mhz": 90.0, "constraint_mhz": 50.0}}
    rep = {"critical_paths": [path("$glbnet$a", "sdram.litedram.x"), path("$glbnet$b", "core.system.y")]}
    assert clock_domains(clocks, rep, 50.0, 50.0) == {"sync": "$glbnet$b", "sdram": "$glbnet$a"}


def test_late_endpoints_group_the_cells_of_a_signal():
    """Endpoints later than the period, of the asked clock only, grouped by the
    signal their cells were made from (cell names as nextpnr wrote them in the
    n10_20_200 build), latest first; arrivals are [earliest, latest]."""
    from rast.gateware.build import late_endpoints
    clk, other = "$glbnet$core.clk", "$glbnet$core.sdram_clk"

    def net(*endpoints):
        return {"endpoints": [{"cell": c, "delay": [0.5, d], "event": f"posedge {e}", "port": "DI"}
                              for c, d, e in endpoints]}
    rep = {"detailed_net_timings": [
        net(("core.pipe0.mac_word.re_TRELLIS_FF_Q_3", 7.2, clk), ("core.pipe0.mac_word.re_TRELLIS_FF_Q", 5.1, clk),
            ("core.pipe0.mac_word.im_TRELLIS_FF_Q_12", 4.9, clk)),
        net(("core.regs.run_count_TRELLIS_FF_Q_DI_CCU2C_S0$CCU2_COMB1", 6.1, clk),
            ("core.regs.run_count[3]", 5.5, clk), ("core.sdram.x_TRELLIS_FF_Q", 9.0, other)),
        net(("core.common.mem.bram8$DP16KD", 5.7, clk))]}
    assert late_endpoints(rep, clk, 5.0) == [("core.pipe0.mac_word.re", 2, 7.2), ("core.regs.run_count", 2, 6.1),
                                             ("core.common.mem.bram8", 1, 5.7)]
    assert late_endpoints(rep, clk, 7.5) == []
    assert late_endpoints({}, clk, 5.0) == []


def test_cli_sdram_option(tmp_path, capsys):
    """`rast build --sdram`: the pool in SDRAM, its words the whole SDRAM unless
    --pool-words is given; refused for a plain device before anything is built."""
    from rast.cli import build_parser, main
    args = build_parser().parse_args(["build", "--sdram", "--out", str(tmp_path / "a")])
    assert args.sdram is True and args.pool_words is None
    args = build_parser().parse_args(["build", "--out", str(tmp_path / "a")])
    assert args.sdram is False and BuildConfig(pool_words=args.pool_words).pool_words == 65536
    out = tmp_path / "b"
    assert main(["build", "--sdram", "--device", "LFE5U-85F", "--out", str(out)]) == 2
    assert "needs a board with SDRAM" in capsys.readouterr().err
    assert main(["build", "--sdram", "--pool-words", "81920", "--out", str(out)]) == 2
    assert "power of two" in capsys.readouterr().err
    assert not out.exists()


def test_nextpnr_options_extra_replaces_placer_options():
    from rast.gateware.build import PLACER_OPTIONS, nextpnr_options
    assert nextpnr_options() == list(PLACER_OPTIONS)
    # an option given again in extra replaces the default (nextpnr refuses an option twice)
    merged = nextpnr_options(["--placer-heap-critexp", "2", "--router", "router2"])
    assert merged.count("--placer-heap-critexp") == 1
    assert merged[merged.index("--placer-heap-critexp") + 1] == "2"
    assert merged[merged.index("--placer-heap-timingweight") + 1] == PLACER_OPTIONS[1]
    assert merged[-2:] == ["--router", "router2"]


def test_the_readme_timing_table_heads_with_the_default_build():
    """The README's timing table is bench/bench_bitstream.py's (between its
    markers), its first row the build `make bitstream` makes: a change of the
    defaults that leaves the table of the old ones fails here."""
    import importlib.util
    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("bench_bitstream", root / "bench" / "bench_bitstream.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    first_label = next(iter(bench.README_ROWS))
    assert bench.LADDER[first_label][1] == {} and bench.command_of({}) == "make bitstream"
    readme = (root / "README.md").read_text()
    table = readme.split(bench.TABLE_BEGIN, 1)[1].split(bench.TABLE_END, 1)[0].strip().splitlines()
    assert len(table) == 2 + len(bench.README_ROWS)
    assert table[2].startswith(f"| {bench.build_name(BuildConfig())} | `make bitstream` |"), table[2]
    cfg = BuildConfig()
    c = cfg.contract()
    assert (c.channels, cfg.sample_rate_mhz, c.slots, cfg.clock_mhz, c.pool_words) == (64, 20, 8, 160, 65_536)


def test_a_following_build_takes_at_most_32_slots_per_pipeline_unless_asked():
    """At 2.5 MS/s the default clock is 160 MHz (M = 64), but a following
    build's is 80 MHz (two pipelines of M = 32), the shape that closes timing;
    --clock-mhz 160 still asks for the one pipeline of 64."""
    from rast.gateware.build import clock_reason
    follow = dict(sample_rate_mhz=2.5, pool="sdram", scan=True, follow_rows=4096)
    cfg = BuildConfig(**follow)
    assert (cfg.clock_mhz, cfg.contract().slots, cfg.contract().pipelines) == (80, 32, 2)
    assert "at most 32 slots per pipeline" in clock_reason(cfg)
    assert (BuildConfig(sample_rate_mhz=2.5).clock_mhz, BuildConfig(sample_rate_mhz=2.5).contract().slots) == (160, 64)
    assert BuildConfig(**follow, clock_mhz=160).contract().slots == 64
    assert BuildConfig(sample_rate_mhz=20, pool="sdram", scan=True, follow_rows=64).clock_mhz == 160


def test_a_router_that_stops_converging_fails_the_build(tmp_path):
    """nextpnr's router1 going round its last arcs (seeds 2 and 3 of the
    64-channel build did for an hour) is killed once its fewest arcs left
    has not fallen for ROUTER_STALL_S, and the build says so; one that keeps
    routing is left alone."""
    import sys
    import time
    from rast.gateware import build as b
    lines = ["Info:    IterCnt |  w/ripup   wo/ripup |  w/r  wo/r |      arcs| batch(sec) total(sec)|",
             "Info:       1000 |       10        990 |    0   990 |      5000|       0.10       0.10|",
             "Info:       2000 |       20       1980 |    0   990 |        24|       0.10       0.20|"]
    stuck = tmp_path / "stuck.py"
    stuck.write_text(f"import time\nfor l in {lines!r}:\n    print(l, flush=True)\ntime.sleep(60)\n")
    t0 = time.monotonic()
    with pytest.raises(b.BuildError, match=r"router stopped converging: 24 arcs still unrouted .* another --seed"):
        b._run([sys.executable, str(stuck)], tmp_path, None, "log", lambda m: None, router_stall_s=0.4)
    assert time.monotonic() - t0 < 30
    done = tmp_path / "done.py"
    done.write_text(f"import time\nfor l in {lines!r}:\n    print(l, flush=True)\n    time.sleep(0.05)\n")
    b._run([sys.executable, str(done)], tmp_path, None, "log", lambda m: None, router_stall_s=0.4)


def test_a_design_that_does_not_fit_is_told_by_the_resources_over_100_percent():
    """nextpnr's utilisation lines of the 512-channel, 2.5 MS/s SDRAM build as
    first synthesised (it could not be placed): the resources above 100 % are
    the ones `rast build` names; a resource at exactly 100 % is not over."""
    from rast.gateware.build import overused_resources
    log = ("Info: Device utilisation:\n"
           "Info: \t          TRELLIS_IO:      84/    365    23%\n"
           "Info: \t              DP16KD:      96/    208    46%\n"
           "Info: \t          TRELLIS_FF:  114852/  83640   137%\n"
           "Info: \t        TRELLIS_COMB:  183747/  83640   219%\n"
           "Info: \t        TRELLIS_RAMW:   10455/  10455   100%\n")
    assert overused_resources(log) == [("TRELLIS_FF", 114852, 83640), ("TRELLIS_COMB", 183747, 83640)]
    assert overused_resources(log.replace("114852", "83640").replace("183747", "1")) == []
