"""Load time over the UART bridge: the line time of ``rast load``'s writes for the examples.

For each farm, the register writes ``rast load`` sends (``manifest_to_register_writes``:
per channel the stream as one burst frame, BASE, LENGTH, PHASE_INC, CRC,
gain, delay, the switch; the block target, whose writes differ from the
board's only in the delay values) are framed as the bridge protocol
frames them (``rast.model.contract.hostproto.group_writes``) and their bytes counted;
at 8N1 a byte is 10 bits on the line. Printed: stream words, frame bytes, and
the line time at 1 Mbaud (the old default) and 3 Mbaud (the FT231X's fastest,
the default now). The bridge takes a byte every 10 x divisor fabric clocks and
a register write every M clocks, so the line, not the block, sets the pace;
the acknowledgements travel back on the other wire at the same time (a host
waits for them only every ``HostBridge.window`` frames: USB latency adds a
few ms per window, not per word).

"realistic 64" is the farm issue 11 names: 64 turbines of 3 blades x 15
scatterers with blade flashes (seed section 4.3.3's 25 rpm windmill) at rpm
10 to 16 and the automatic stream rate; its streams need the SDRAM pool.

Run: ``.venv/bin/python bench/bench_load.py``.
"""

import tomllib
from pathlib import Path

import numpy as np

from rast.model.physics.farm import parse_config
from rast.model.contract.fixedpoint import ReplayContract, POOL_BANK_WORDS
from rast.model.contract.hostproto import line_bytes, line_seconds
from rast.model.contract.loadplan import manifest_to_register_writes
from rast.model.physics.stream import build_farm_streams

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
BAUDS = (1_000_000, 3_000_000)


def realistic_64() -> dict:
    """64 copies of seed 4.3.3's 15-scatterer windmill, rpm 10..16, 300 m apart."""
    cfg = tomllib.loads((EXAMPLES / "sec4_3_3_realistic.toml").read_text())
    mill = next(w for w in cfg["windmill"] if w["num_rcs"] == 15)
    rpms = np.linspace(10.0, 16.0, 64)
    cfg["windmill"] = [dict(mill, name=f"t{k:02d}", range=round(3.0 + 0.3 * k, 3), rpm=round(float(r), 3))
                       for k, r in enumerate(rpms)]
    return cfg


def farms():
    for name in ("two_windmills.toml", "sec4_3_4_four_windmills.toml", "farm_atc_sband.toml",
                 "farm_layout.toml", "farm_sdram_64.toml"):
        yield name, tomllib.loads((EXAMPLES / name).read_text())
    yield "realistic 64 (3 x 15 scatterers, flashes)", realistic_64()


def main():
    print(f"{'farm':<44} {'turbines':>8} {'stream words':>12} {'line bytes':>11} "
          + " ".join(f"{f'at {b / 1e6:g} Mbaud':>13}" for b in BAUDS))
    for name, cfg in farms():
        cfg.pop("ram_depth", None)
        fs = build_farm_streams(parse_config(cfg), check_ram_depth=False)
        words = sum(s.plan.length for s in fs.streams)
        n = len(fs.streams)
        pool = -(-words // POOL_BANK_WORDS) * POOL_BANK_WORDS
        # a block big enough for the farm: the line time depends on the writes only
        contract = ReplayContract(channels=n, pool_words=pool, max_delay=65534, max_tap=16382)
        writes = manifest_to_register_writes(fs.manifest(), contract, streams=[s.words for s in fs.streams],
                                             target="block")
        nbytes = line_bytes(writes)
        print(f"{name:<44} {n:>8} {words:>12,} {nbytes:>11,} "
              + " ".join(f"{line_seconds(writes, b):>11.2f} s" for b in BAUDS))


if __name__ == "__main__":
    main()
