"""Make examples/farm_layout_atc_512.csv: six synthetic farms round an airport radar.

A SYNTHETIC layout in the columns of the US Wind Turbine Database (USWTDB):
512 turbines in six farms at different bearings and ranges (10-60 km) from a
made-up airport surveillance radar at 35.2000 N, 101.7000 W. Each farm is a
grid of rows (the row direction, spacing and jitter its own), one turbine
model per farm, positions jittered by a seeded generator: the file is the
same on every run. No real farm or radar is described.

    .venv/bin/python examples/make_atc_512_layout.py

examples/farm_atc_512.toml is made from it by `rast farm` (the command is in
docs/stream_sharing.md and in the CSV's header).
"""

from pathlib import Path

import numpy as np

RADAR_LAT, RADAR_LON = 35.2000, -101.7000
EARTH_RADIUS_M = 6_371_000.0

#: (project, bearing of the farm's first turbine from the radar in deg, its
#:  range in km, rows, turbines per row, along-row bearing deg, along-row
#:  spacing m, row spacing m, manufacturer, model, capacity kW, hub m, rotor m, year)
FARMS = (
    ("Synthetic Mesa Wind", 18.0, 13.0, 8, 12, 110.0, 420.0, 700.0, "GE Wind", "GE2.5-116", 2500, 90, 116, 2016),
    ("Synthetic Caprock Wind", 72.0, 24.0, 8, 10, 160.0, 380.0, 650.0, "Vestas", "V110-2.0", 2000, 95, 110, 2018),
    ("Synthetic Draw Wind", 138.0, 39.0, 8, 12, 95.0, 330.0, 600.0, "GE Wind", "GE1.5-77", 1500, 80, 77, 2008),
    ("Synthetic Playa Wind", 203.0, 17.0, 8, 8, 120.0, 440.0, 720.0, "Siemens", "SWT-2.3-108", 2300, 80, 108, 2014),
    ("Synthetic Breaks Wind", 262.0, 54.0, 8, 12, 15.0, 420.0, 700.0, "GE Wind", "GE2.5-116", 2500, 90, 116, 2019),
    ("Synthetic Llano Wind", 318.0, 29.0, 8, 10, 60.0, 380.0, 650.0, "Vestas", "V110-2.0", 2000, 95, 110, 2017),
)
JITTER_M = 40.0

COLUMNS = ("case_id,faa_ors,faa_asn,usgs_pr_id,eia_id,t_state,t_county,t_fips,p_name,p_year,p_tnum,p_cap,"
           "t_manu,t_model,t_cap,t_hh,t_rd,t_rsa,t_ttlh,retrofit,retrofit_year,t_conf_atr,t_conf_loc,"
           "t_img_date,t_img_src,xlong,ylat")


def _offset(lat, lon, east_m, north_m):
    """(lat, lon) of a point east_m, north_m from (lat, lon): a local flat
    earth, ample for a farm's few kilometres (rast farm does the geodesy)."""
    lat2 = lat + np.degrees(north_m / EARTH_RADIUS_M)
    lon2 = lon + np.degrees(east_m / (EARTH_RADIUS_M * np.cos(np.radians(lat))))
    return lat2, lon2


def grid_offsets_m(bearing, range_km, row, place, along, spacing, row_gap):
    """East and north (m) from the radar of the turbine at ``place`` in row
    ``row`` of a farm's grid (``FARMS``' columns), without its jitter."""
    b, a = np.radians(bearing), np.radians(along)
    across = a + np.pi / 2
    east = range_km * 1e3 * np.sin(b) + place * spacing * np.sin(a) + row * row_gap * np.sin(across)
    north = range_km * 1e3 * np.cos(b) + place * spacing * np.cos(a) + row * row_gap * np.cos(across)
    return east, north


def layout_rows(seed=512, farms=FARMS, radar=(RADAR_LAT, RADAR_LON), first_case=3200001, county="Synthetic County, TX"):
    """The layout's CSV rows: each farm a jittered grid (``FARMS``' columns)."""
    rng = np.random.default_rng(seed)
    rows, case = [], first_case
    for (name, bearing, range_km, n_rows, per_row, along, spacing, row_gap,
         manu, model, cap, hub, rotor, year) in farms:
        count = n_rows * per_row
        swept = np.pi * (rotor / 2) ** 2
        for r in range(n_rows):
            for k in range(per_row):
                jitter = rng.uniform(-JITTER_M, JITTER_M, size=2)
                e, n = grid_offsets_m(bearing, range_km, r, k, along, spacing, row_gap)
                lat, lon = _offset(*radar, e + jitter[0], n + jitter[1])
                rows.append(f'{case},,,,,TX,"{county}",48999,{name},{year},{count},'
                            f"{count * cap / 1000:.1f},{manu},{model},{cap},{hub},{rotor},{swept:.2f},"
                            f"{hub + rotor / 2:.1f},0,,3,3,,synthetic,{lon:.6f},{lat:.6f}")
                case += 1
    return rows


HEADER = f"""\
# SYNTHETIC wind farm layout in the columns of the US Wind Turbine Database (USWTDB).
# Made by examples/make_atc_512_layout.py: 512 turbines in six made-up farms round a
# made-up airport radar at {RADAR_LAT:.4f} N, {-RADAR_LON:.4f} W (bearings 18-318 deg, 10-60 km).
# No real farm or radar is described. examples/farm_atc_512.toml is made from this file by
#   rast farm examples/farm_layout_atc_512.csv --radar 35.2,-101.7,20 --wind-from 230 \\
#            --wind-speed 9 --radar-frequency 2800 --prf 1000 --pulse-width 1 --sample-rate 2.5 \\
#            --stream-oversampling 2.5 --ram-depth 8388608 --share-aspect-deg 0.5 \\
#            --out examples/farm_atc_512.toml
"""

if __name__ == "__main__":
    path = Path(__file__).with_name("farm_layout_atc_512.csv")
    rows = layout_rows()
    path.write_text(HEADER + COLUMNS + "\n" + "\n".join(rows) + "\n")
    print(f"wrote {path} ({len(rows)} turbines)")
