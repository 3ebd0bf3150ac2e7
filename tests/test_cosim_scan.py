"""The antenna scan in the replay block's Verilog under cocotb (Verilator):
the radar's ACP and ARP pins driven clock by clock, with jitter, glitches
shorter than the board's 16-clock filter and a missing ARP, beside input
samples and the pattern's load through the bus; every output sample equal to
the bit-exact model's (``rast.sim.tb_scan``). And ``rast cosim`` of a config
whose beam turns freely, bit-exact, its PPI drawn from the RTL's gates."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rast.gateware.verilog import verilog_text
from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.fixedpoint import pack_iq, WRITE_STAGING
from rast.model.contract.powerup import ChannelInit
from rast.model.contract.regmap import SCAN_RESTART
from rast.model.contract.scan import PATTERN_ONE
from rast.sim.pytest_support import cocotb_run
from rast.sim.scan_drive import radar_pulses

#: Cosimulations: left out of `make test-fast`, run by `make test` and CI.
pytestmark = pytest.mark.slow

KW = dict(channels=4, slots=2, pool_words=256, max_delay=20, max_tap=6, interpolation="hold")


def _inits(rng, azimuths):
    out, base = [], 0
    for l, az in enumerate(azimuths):
        n = int(rng.integers(2, 9))
        words = pack_iq(rng.integers(-20000, 20000, n), rng.integers(-20000, 20000, n))
        out.append(ChannelInit(tuple(int(w) for w in words), int(rng.integers(0, 1 << 30)),
                               int(rng.integers(1 << 15, 1 << 16)), int(rng.integers(0, 7)), True, base,
                               azimuth=az))
        base += n
    return out


def test_the_beam_follows_the_radar_s_pulses_bit_exact_in_verilator():
    rng = np.random.default_rng(11)
    inits = _inits(rng, [0, 300, 65536 - 500, 2000])
    top = WindFarmReplay(**KW, scan=True, init=inits)           # the properties the bench needs
    rmap = top.register_map
    words = rng.integers(1, PATTERN_ONE + 1, 1024)
    ops = [(0, "w", rmap.addr("PATTERN"), 4 | 300 << 16), (0, "w", rmap.addr("PATTERN_ADDR"), 0)]
    ops += [(0, "w", rmap.addr("PATTERN_DATA"), int(w)) for w in words]
    ops += [(0, "r", rmap.addr("PATTERN_CRC"), 0), (0, "w", rmap.addr("SCAN_CTRL"), 2 | 8 | SCAN_RESTART)]
    # ACPs 80 clocks apart, 20 high (each moved by up to 3), glitches of 10:
    # every pulse and gap outlasts the 16-clock filter, the glitches do not
    spacing, n, t0 = 80, 256, 9000
    pulses = radar_pulses(rng, t0, n, 3, spacing, 3, 20, missing=(2,), glitch=10)
    T = (t0 + 3 * n * spacing + 40 * spacing) // 2
    ops += [(k, "r", rmap.addr(name), 0) for k in range(T // 10, T, T // 10)
            for name in ("STATUS", "SCAN_STATUS", "ACP_PER_REV")]
    verilog = verilog_text(KW["channels"], **{k: v for k, v in KW.items() if k != "channels"}, scan=True,
                           init=inits, name="scan_top")
    run = cocotb_run({"scan_top.v": verilog}, "scan_top", "rast.sim.tb_scan", "scan", simulator="verilator",
                     name="scan-acp", label="scan_top",
                     tb_params=dict(contract={**KW, "scan": True},
                                    inits=[dataclasses.asdict(i) for i in inits], steps=T, seed=4,
                                    ops=ops, pulses=pulses, acp_lead=top.acp_lead,
                                    filter_clocks=top.acp_filter_clocks, write_staging=WRITE_STAGING))
    rep = json.loads((run / "scan.json").read_text())
    assert rep["per_rev"] == n, "the revolution's count was not learned"
    status = [got for _, addr, got in rep["reads"] if addr == rmap.addr("STATUS")]
    assert any(v >> 2 & 1 for v in status), "the missing ARP was not flagged"
    assert rep["nonzero"] > T // 4


CONFIG = Path(__file__).resolve().parent.parent / "examples" / "scan_two_turbines.toml"


def test_rast_cosim_of_a_turning_config_and_its_ppi(tmp_path):
    """Half a revolution at 600 rpm through the Verilog, bit-exact; each
    turbine's gate is brightest in the dwell of its azimuth and the others
    lie under the pattern's floor; the PPI drawn from the RTL's gates."""
    config = CONFIG
    out = tmp_path / "out"
    rast = [sys.executable, "-m", "rast.cli"]
    r = subprocess.run(rast + ["cosim", str(config), "--seconds", "0.05", "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "mismatches          0" in r.stdout and "antenna scan        free" in r.stdout
    gates = np.load(out / "gates.npy")                      # (pulses, gates): 2 km, 3 km
    beam = (20 + 600 / 60 * 360 * np.arange(gates.shape[0]) / 20000) % 360
    for g, az in enumerate((45, 120)):
        power = np.abs(gates[:, g]) ** 2
        on = np.abs(beam - az) < 2
        off = np.abs(beam - az) > 20
        assert abs(beam[np.argmax(power)] - az) < 8, f"gate {g} is brightest at {beam[np.argmax(power)]:.1f} deg"
        assert 10 * np.log10(power[on].mean() / power[off].mean()) > 30
    png = tmp_path / "ppi.png"
    r = subprocess.run(rast + ["preview", str(config), "--ppi", "--gates", str(out), "--out", str(png)],
                       capture_output=True, text=True)
    assert r.returncode == 0 and png.stat().st_size > 10_000, r.stderr
    assert "strongest dwell 40-48" in r.stdout, r.stdout
