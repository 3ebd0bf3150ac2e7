"""Board top, clocking and the bitstream flow.

The fast tests elaborate the ULX3S top and check the PLL and pin map; the
slow one builds one pipeline of the engine on the ULX3S-85F with Yosys,
nextpnr and ecppack and checks its report.
"""

import json
import subprocess
import sys

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
    assert len(rows) == 16 + 1 + 16 + 1 + 1
    assert len(set(balls)) == len(balls)


def test_plain_device_needs_pinmap_for_other_packages():
    with pytest.raises(ValueError, match=r"^Package BG256 needs a pin map"):
        make_platform(None, device="LFE5U-25F", package="BG256", speed=6)
    assert make_platform(None, device="LFE5U-85F", package="BG381", speed="6").device == "LFE5U-85F"


@pytest.mark.parametrize("board,device", [("ulx3s-85f", None), (None, "LFE5U-45F")])
def test_elaborates_for_ecp5(tmp_path, board, device):
    """Platform files (RTLIL, LPF) are produced; the sample interface is DDR on the header."""
    cfg = BuildConfig(board=board, device=device, package="BG381", speed="8", channels=2,
                      pool_words=256, max_delay=254, max_tap=62)
    rep = build(cfg, tmp_path, quiet=True, run_tools=False)
    il = (tmp_path / "rast_top.il").read_text()
    lpf = (tmp_path / "rast_top.lpf").read_text()
    assert il.count("cell \\IDDRX1F") == 16 and il.count("cell \\ODDRX1F") == 16 + 3
    assert "cell \\EHXPLLL" in il
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


#: The slow build: one pipeline of the engine (10 channels, M = 10 slots) on
#: the full board top at a 100 MHz fabric clock and 10 MS/s, with the default
#: build's delays (8190 + 2046 samples) and a 16,384-word pool: the default
#: build's structure at a size and clock CI's two cores route in minutes
#: (docs/bitstream.md has the 200 MHz and 64-channel rungs, measured by
#: bench/bench_bitstream.py).
CI_BUILD = ["--channels", "10", "--sample-rate-mhz", "10", "--clock-mhz", "100", "--pool-words", "16384"]


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
    assert rep["config"]["channels"] == 10 and rep["config"]["pipelines"] == 1
    assert rep["build"]["sample_rate_hz"] == 10_000_000 and rep["build"]["slots"] == 10
    assert rep["build"]["interpolation"] == "fir"
    r = rep["resources"]
    assert r["dsps"]["used"] == 10 and r["dsps"]["available"] == 156
    assert r["block_rams"]["used"] <= r["block_rams"]["available"] == 208
    assert 0 < r["luts"]["used"] < r["luts"]["available"]
    assert 0 < r["ffs"]["used"] < r["ffs"]["available"]
    assert rep["memory"]["pool_words"] == 16384
    assert rep["memory"]["delay_samples"] == {"common": 8190, "tap": 2046}
    assert "clock" in proc.stdout and "met" in proc.stdout
