"""The air-traffic scale (issue: 512 turbines for an air-traffic radar):
what the host and the contract need for more than 255 channels."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from rast.model.contract.fixedpoint import ReplayContract


@pytest.mark.parametrize("channels, slots", [(64, 8), (300, 64), (512, 64)])
def test_the_loader_reads_channel_counts_beyond_255_from_config(channels, slots):
    """CONFIG holds N's low 8 bits and, in channels_hi (only in a build of
    more than 255), the rest (512 channels at 64 slots: the air-traffic build)."""
    from rast.load import _read_contract
    from rast.model.contract.hostproto import BRIDGE_ID
    from rast.model.contract.regmap import register_map

    contract = ReplayContract(channels=channels, slots=slots, pool="sdram", pool_words=1 << 23,
                              sample_rate_hz=2_500_000)
    rmap = register_map(contract)

    class Board:                      # answers every read with the register's power-up value
        def version(self):
            return BRIDGE_ID

        def read(self, addr):
            r = rmap.by_addr(addr)
            return sum(f.reset << f.lsb for f in r.fields if f.access == "ro")

    hi = [f.reset for f in rmap.reg("CONFIG").fields if f.name == "channels_hi"]
    assert hi == ([channels >> 8] if channels > 255 else [])      # (no field, no change, up to 255)
    assert _read_contract(Board()) == contract


# ------------------------------------------------------------------ the 512-turbine example

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ATC_512 = EXAMPLES / "farm_atc_512.toml"
LAYOUT_512 = EXAMPLES / "farm_layout_atc_512.csv"


def _command_in_header(path):
    """The `rast farm` arguments written in a layout's header comment."""
    text = " ".join(line.lstrip("#").replace("\\", " ") for line in path.read_text().splitlines()
                    if line.startswith("#"))
    words = text.split("rast farm ", 1)[1].split()
    return words[1:words.index("--out")]                     # after the layout, up to --out


def test_the_512_turbine_layout_and_farm_regenerate_identically(tmp_path, capsys):
    """examples/farm_layout_atc_512.csv is what its script writes, and
    examples/farm_atc_512.toml what `rast farm` makes of it with the command
    in the layout's header, byte for byte."""
    import runpy
    from rast.cli import main
    script = runpy.run_path(str(EXAMPLES / "make_atc_512_layout.py"))
    rows = script["layout_rows"]()
    assert len(rows) == 512
    assert LAYOUT_512.read_text() == script["HEADER"] + script["COLUMNS"] + "\n" + "\n".join(rows) + "\n"
    out = tmp_path / "farm.toml"
    assert main(["farm", str(LAYOUT_512), *_command_in_header(LAYOUT_512), "--out", str(out)]) == 0
    capsys.readouterr()
    assert out.read_text() == ATC_512.read_text()


def test_the_512_turbine_example_fits_the_512_channel_sdram_build():
    """examples/farm_atc_512.toml: six farms round the radar (bearings over
    more than 270 degrees, ranges 8-60 km), one channel per turbine in the
    512-channel SDRAM build at 2.5 MS/s (the registers the load writes, the
    pool's regions, the FIR's rate), the SDRAM's words per second asked
    under a quarter of what it delivers, and the streams shared: fewer words than one
    stream per turbine, each aspect-shared stream measured at 70 dB or more."""
    from rast.gateware.build import BuildConfig
    from rast.model.contract.fixedpoint import PHASE_FRAC_BITS, SDRAM_CLOCK_HZ, SDRAM_WORD_CLOCKS
    from rast.model.contract.loadplan import channel_regions, manifest_to_register_writes, pool_layout
    from rast.model.physics.farm import load_config
    from rast.model.physics.layout import azimuth_spread_deg
    from rast.model.physics.stream import build_farm_streams

    farm = load_config(ATC_512)
    assert len(farm.windmills) == 512 and farm.sample_rate_mhz == 2.5
    ranges = [w.range_km for w in farm.windmills]
    assert 8 <= min(ranges) and max(ranges) <= 60
    assert azimuth_spread_deg([w.azimuth_deg for w in farm.windmills])[2] > 270
    assert len({(round(w.rpm, 3), float(w.radius_m[-1])) for w in farm.windmills}) >= 3      # several turbine kinds

    cfg = BuildConfig(channels=512, sample_rate_mhz=2.5, pool="sdram")
    c = dataclasses.replace(cfg.contract(), sample_rate_hz=2_500_000)
    assert (c.slots, c.pipelines, cfg.clock_mhz) == (64, 8, 160)
    fs = build_farm_streams(farm)
    manifest = fs.manifest()
    manifest_to_register_writes(manifest, c, target="board")     # raises on anything the build refuses
    channels = manifest["registers"]["channels"]
    assert len(channels) == 512
    pool_layout([ch["length"] for ch in channels], c.pool_words, channel_regions(channels))
    inc = [ch["phase_increment"] for ch in channels]
    assert max(inc) <= c.max_phase_increment
    asked = sum(i / (1 << PHASE_FRAC_BITS) for i in inc) * 2.5e6    # words a second, all channels
    assert asked < SDRAM_CLOCK_HZ / SDRAM_WORD_CLOCKS / 4         # a quarter of the controller's words

    own = sum(ch["length"] for ch in channels)
    regions = {ch["pool_region"]["stream"] for ch in channels if "pool_region" in ch}
    assert len(regions) < 512 / 4 and fs.pool_words < own / 4
    by_aspect = [s.share.sfdr_db for s in fs.streams if s.share is not None and s.share.sfdr_db is not None]
    assert len(by_aspect) > 256 and min(by_aspect) >= 70


@pytest.mark.parametrize("option, value, needle", [("--share-aspect-deg", "-1", "angle in [0, 180]"),
                                                   ("--stream-oversampling", "0", "at least 2")])
def test_rast_farm_refuses_a_bad_sharing_or_oversampling_option(tmp_path, capsys, option, value, needle):
    from rast.cli import main
    layout = tmp_path / "layout.csv"
    layout.write_text("x,y\n0,3000\n")
    out = tmp_path / "farm.toml"
    with pytest.raises(SystemExit):
        main(["farm", str(layout), "--radar", "0,0,20", "--wind-from", "90", option, value, "--out", str(out)])
    assert needle in capsys.readouterr().err and not out.exists()


def test_the_cosimulation_leaves_out_the_doppler_check_where_the_prf_aliases():
    """An S-band turbine's maximum Doppler (700 Hz and more in the 512-turbine
    example) beyond the air-traffic radar's ±PRF/2 (500 Hz) aliases: its
    outermost line in a spectrogram is not its maximum, and the e2e check of
    it is left out; the 64-turbine S-band example (at most 147 Hz) keeps it."""
    from rast.sim.e2e import doppler_aliased, prepare
    atc512 = prepare(ATC_512, 0.01, slots=64, pool="sdram", preload=True)
    assert max(s.plan.max_doppler_hz for s in atc512.streams.streams) > 500 and doppler_aliased(atc512)
    sband = prepare(EXAMPLES / "farm_atc_sband.toml", 0.01)
    assert max(s.plan.max_doppler_hz for s in sband.streams.streams) < 500 and not doppler_aliased(sband)


def test_a_range_doppler_map_leaves_the_range_between_farms_empty():
    """Bins at 10.00 and 10.06 km and one at 30 km: the close pair meet half
    way (10.03), the outer sides reach 1 % of the 20 km shown (0.2 km), and
    the 19.5 km between 10.26 and 29.8 is a row of its own that no bin fills."""
    from rast.model.radar.plot import range_bands
    edges, row, low, high = range_bands([10.0, 10.06, 30.0])
    assert np.allclose(edges, [9.8, 10.03, 10.26, 29.8, 30.2])
    assert list(row) == [0, 1, 3] and 2 not in row
    assert np.allclose(low, [9.8, 10.03, 29.8]) and np.allclose(high, [10.03, 10.26, 30.2])
