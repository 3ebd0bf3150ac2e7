"""Make examples/farm_layout_follow.csv: a 360° scene of more than 2048 turbines.

A SYNTHETIC layout in the columns of the US Wind Turbine Database (USWTDB):
farms at bearings all round a made-up airport surveillance radar at
32.4000 N, 100.0000 W, 5-60 km away, for channels that follow the beam
(docs/beam_following.md). The farms are drawn by a seeded generator (the
file is the same on every run): near farms large and spread over tens of
degrees, far ones smaller, as a region dense with wind farms looks from an
airport. Each farm is a jittered grid, as in make_atc_512_layout.py. The scene
is drawn for the 64-channel following build: a farm whose grid would put more
than BUDGET turbines within WINDOW_DEG of bearing anywhere (the beam's window
at -60 dB with its guard is 4.6 degrees) is drawn again, turned and smaller,
so that the build holds every azimuth with channels to spare. No real farm
or radar is described.

    .venv/bin/python examples/make_follow_layout.py

examples/farm_follow.toml is made from it by `rast farm` (the command is in
docs/beam_following.md and in the CSV's header).
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_atc_512_layout import COLUMNS, grid_offsets_m, layout_rows  # noqa: E402

RADAR_LAT, RADAR_LON = 32.4000, -100.0000
#: (manufacturer, model, capacity kW, hub m, rotor m)
MODELS = (("GE Wind", "GE2.5-116", 2500, 90, 116), ("Vestas", "V110-2.0", 2000, 95, 110),
          ("GE Wind", "GE1.5-77", 1500, 80, 77), ("Siemens", "SWT-2.3-108", 2300, 80, 108))
FARM_COUNT = 48
#: Turbines allowed within any WINDOW_DEG of bearing (the 64-channel build's
#: channels less a margin for the grid's jitter and the guard), and of one
#: farm alone (room for its neighbours' edges).
BUDGET, FARM_BUDGET, WINDOW_DEG = 58, 36, 5.0
DRAWS = 50


def _bearings_deg(bearing, range_km, n_rows, per_row, along, spacing, row_gap):
    """The bearings of a farm's grid without its jitter (as layout_rows lays it)."""
    place, row = np.meshgrid(np.arange(per_row), np.arange(n_rows))
    e, n = grid_offsets_m(bearing, range_km, row, place, along, spacing, row_gap)
    return np.degrees(np.arctan2(e, n)).ravel() % 360


def _most_in_window(bearings_deg):
    """The most bearings within any WINDOW_DEG round the circle."""
    b = np.sort(bearings_deg)
    ring = np.concatenate([b, b + 360])
    return int((np.searchsorted(ring, b + WINDOW_DEG, side="right") - np.arange(b.size)).max())


def farms(seed=2048):
    """The farms' rows for ``layout_rows``: bearings spread round the circle,
    ranges 5-60 km, fewer turbines the farther (a farm's azimuth extent
    shrinks with range); a farm that would crowd a window past its budget is
    drawn again (turned, and smaller every fifth draw)."""
    rng = np.random.default_rng(seed)
    bearings = (np.arange(FARM_COUNT) * 360.0 / FARM_COUNT + rng.uniform(-1.5, 1.5, FARM_COUNT)) % 360
    out, placed = [], np.zeros(0)
    for k, bearing in enumerate(bearings):
        near = k % 2 == 0                  # near and far farms by turns round the circle
        range_km = float(rng.uniform(11.0, 28.0) if near else rng.uniform(32.0, 50.0))
        n_rows = int(rng.integers(5, 8)) if near else int(rng.integers(2, 4))
        per_row = int(rng.integers(10, 15)) if near else int(rng.integers(8, 12))
        spacing, row_gap = float(rng.choice([330.0, 380.0, 420.0])), float(rng.choice([600.0, 650.0, 700.0]))
        for draw in range(DRAWS):
            along = round(float(rng.uniform(0, 180)), 1)
            grid = _bearings_deg(bearing, range_km, n_rows, per_row, along, spacing, row_gap)
            if _most_in_window(grid) <= FARM_BUDGET and _most_in_window(np.concatenate([placed, grid])) <= BUDGET:
                break
            if draw % 5 == 4:              # smaller: a row fewer, or a turbine fewer in each row
                n_rows, per_row = (n_rows - 1, per_row) if n_rows > 2 else (n_rows, per_row - 1)
        else:
            raise RuntimeError(f"farm {k + 1} at {bearing:.1f} deg does not fit {BUDGET} turbines per "
                               f"{WINDOW_DEG} deg in {DRAWS} draws")
        placed = np.concatenate([placed, grid])
        manu, model, cap, hub, rotor = MODELS[k % len(MODELS)]
        out.append((f"Synthetic Ring Wind {k + 1}", round(float(bearing), 2), round(range_km, 2), n_rows, per_row,
                    along, spacing, row_gap, manu, model, cap, hub, rotor, int(rng.integers(2008, 2021))))
    return tuple(out)


HEADER = f"""\
# SYNTHETIC wind farm layout in the columns of the US Wind Turbine Database (USWTDB).
# Made by examples/make_follow_layout.py: {FARM_COUNT} made-up farms all round a made-up
# airport radar at {RADAR_LAT:.4f} N, {-RADAR_LON:.4f} W (5-60 km). No real farm or radar is described.
# examples/farm_follow.toml is made from this file by
#   rast farm examples/farm_layout_follow.csv --radar 32.4,-100.0,20 --wind-from 200 \\
#            --wind-speed 9 --radar-frequency 2800 --prf 1000 --pulse-width 1 --sample-rate 2.5 \\
#            --stream-oversampling 2.5 --ram-depth 8388608 --share-aspect-deg 0.5 \\
#            --scan-rpm 12.5 --beamwidth-deg 1.4 --sidelobe-db -70 \\
#            --out examples/farm_follow.toml
"""


def rows():
    return layout_rows(seed=2048, farms=farms(), radar=(RADAR_LAT, RADAR_LON), first_case=3300001,
                       county="Synthetic Ring County, TX")


if __name__ == "__main__":
    path = Path(__file__).with_name("farm_layout_follow.csv")
    text_rows = rows()
    path.write_text(HEADER + COLUMNS + "\n" + "\n".join(text_rows) + "\n")
    print(f"wrote {path} ({len(text_rows)} turbines)")
