"""Turbines per board against the RTS sample rate, block RAM and SDRAM pools.

Usage: python bench/bench_capacity.py [--plot docs/turbines_per_board.png]

For each sample rate (1, 2.5, 5, 10, 20, 100 MS/s) on the ULX3S's
LFE5U-85F: the slots per pipeline M and the fabric clock (the build's
default: the largest multiple of the rate at or below 160 MHz, M at most
64), then the turbines one board replays at once, each on its own channel,
with room in the pool to reload one while all play:

* block RAM pool: the most turbines whose pool, delay windows and
  multipliers fit the device's DP16KD and MULT18X18D
  (``rast.gateware.capacity.turbines_per_device``);
* SDRAM pool (8,388,608 words): the channels the block RAMs and multipliers
  allow, at most the contract's 512, and at most the streams the SDRAM holds;
  beside it the SDRAM's bandwidth bound: the words a second those channels
  ask when every one plays the fastest stream the contract lets it
  (``ReplayContract.max_phase_increment``: the FIR's limit, or the pool's
  share per channel) against the words the controller delivers (one per
  SDRAM_WORD_CLOCKS of its clock).

The reference turbine is the NREL 5-MW class (63 m blades, 12.1 rpm, three
blades) face-on to an S-band radar (2.8 GHz), its stream at 4x its maximum
Doppler (``rast.model.physics.stream.plan_stream``; the header line prints
its figures).
The FIR interpolator plays at most sample rate / 768 words a second; where
that is below the turbine's stream rate the row says so (linear
interpolation or a lower ``stream_oversampling`` plays it).

These are resource bounds (block RAM, multipliers, the channel limit): LUTs,
flip-flops and timing are known only where a build was made, and the row
shows it from ``build/bench_bitstream/*/seed*/report.json`` when present
(``bench/bench_bitstream.py`` makes them).
"""

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rast.gateware.build import BuildConfig, FABRIC_CLOCK_MHZ                 # noqa: E402
from rast.gateware.capacity import DEVICE_BLOCKS, max_channels, turbines_per_device  # noqa: E402
from rast.model.contract.fixedpoint import (FIR_MAX_INCREMENT, PHASE_FRAC_BITS, SDRAM_CLOCK_HZ,  # noqa: E402
                                            SDRAM_MAX_POOL_WORDS, SDRAM_WORD_CLOCKS, ReplayContract)
from rast.model.physics.config import Farm, Radar, Windmill                  # noqa: E402
from rast.model.physics.stream import plan_stream                            # noqa: E402

import numpy as np                                                           # noqa: E402

RATES_MHZ = (1.0, 2.5, 5.0, 10.0, 20.0, 100.0)
DEVICE = "LFE5U-85F"


def reference_plan(sample_rate_mhz):
    """The reference turbine's stream plan at ``sample_rate_mhz``."""
    radius = np.linspace(63.0 / 8, 63.0, 8)
    turbine = Windmill("nrel5mw", 30.0, 3, 12.1, 0.0, 0.0, radius, np.full(8, 0.5), np.zeros(8))
    farm = Farm(sample_rate_mhz, Radar(2800.0, 1000.0, 1.0, 100.0), (turbine,))
    return plan_stream(turbine, farm)


def slots_for(rate_mhz):
    return min(ReplayContract.MAX_SLOTS, max(1, int(FABRIC_CLOCK_MHZ // rate_mhz + 1e-9)))


def measured_builds():
    """{(sample rate MHz, pool, channels): [[fmax per seed], seeds met]} from the bench's reports."""
    out = {}
    for path in sorted((ROOT / "build" / "bench_bitstream").glob("*/seed*/report.json")):
        report = json.loads(path.read_text())
        cfg = report["config"]
        if cfg.get("scan"):           # (the default with the antenna scan: its own table in the README)
            continue
        key = (cfg["sample_rate_mhz"], cfg.get("pool", "bram"), cfg["channels"])
        fmax = report.get("timing", {}).get("fmax_mhz")
        entry = out.setdefault(key, [[], 0])
        entry[0].append(fmax)
        entry[1] += bool(report.get("timing", {}).get("met"))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", type=Path, default=None, help="PNG of turbines per board against sample rate")
    args = ap.parse_args(argv)
    cfg = BuildConfig()
    depths = {"max_delay": cfg.max_delay, "max_tap": cfg.max_tap}
    brams, dsps = DEVICE_BLOCKS[DEVICE]
    builds = measured_builds()
    ref = reference_plan(20.0)
    print(f"Turbines per {DEVICE} ({brams} DP16KD, {dsps} MULT18X18D), FIR interpolation, common delay "
          f"{cfg.max_delay} + window {cfg.max_tap}; reference turbine: NREL 5-MW face-on at 2.8 GHz, "
          f"maximum Doppler {ref.max_doppler_hz:,.0f} Hz, stream {ref.stream_rate_hz:,.0f} words/s, "
          f"{ref.length:,} words")
    print("| MS/s | M | fabric MHz | ref. words | FIR plays it | block RAM pool: turbines (limit) | "
          "SDRAM pool: turbines (limit) | SDRAM words/s: asked / delivered | "
          "built (channels, pool: seeds met, fmax MHz) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    rows = []
    for rate in RATES_MHZ:
        m = slots_for(rate)
        plan = reference_plan(rate)
        fir_ok = plan.phase_increment <= FIR_MAX_INCREMENT
        fir_limit_hz = FIR_MAX_INCREMENT / (1 << PHASE_FRAC_BITS) * rate * 1e6
        bram_n, _, bram_limit = turbines_per_device(plan.length, DEVICE, slots=m, **depths)
        ch, ch_limit = max_channels(DEVICE, slots=m, pool="sdram", pool_words=SDRAM_MAX_POOL_WORDS, **depths)
        held = SDRAM_MAX_POOL_WORDS // plan.length - 1
        sdram_n, sdram_limit = (ch, ch_limit) if ch <= held else (held, "SDRAM words")
        # every channel at the fastest stream the contract lets it play, against
        # the controller's one word per SDRAM_WORD_CLOCKS
        c = ReplayContract(channels=sdram_n, slots=m, pool="sdram", pool_words=SDRAM_MAX_POOL_WORDS, **depths)
        asked = sdram_n * c.max_phase_increment / (1 << PHASE_FRAC_BITS) * rate * 1e6
        delivered = SDRAM_CLOCK_HZ / SDRAM_WORD_CLOCKS
        built = "; ".join(
            f"{n}, {pool}: {met}/{len(f)}, {min(x for x in f if x is not None):.1f}-{max(x for x in f if x is not None):.1f}"
            for (r, pool, n), (f, met) in sorted(builds.items()) if r == rate and any(x is not None for x in f))
        rows.append((rate, bram_n, sdram_n, fir_ok))
        print(f"| {rate:g} | {m} | {m * rate:g} | {plan.length:,} | "
              f"{'yes' if fir_ok else f'no: {plan.stream_rate_hz:,.0f} Hz > {fir_limit_hz:,.0f} Hz'} | "
              f"{bram_n} ({bram_limit}) | {sdram_n} ({sdram_limit}) | {asked / 1e6:.2f} M / {delivered / 1e6:.2f} M | "
              f"{built or '-'} |")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(7, 4.2))
        rates = [r[0] for r in rows]
        ax.plot(rates, [r[1] for r in rows], "o-", label="block RAM pool")
        ax.plot(rates, [r[2] for r in rows], "s-", label="SDRAM pool")
        slow = [r for r in rows if not r[3]]
        if slow:
            ax.plot([r[0] for r in slow], [r[2] for r in slow], "ws", ms=4,
                    label="(white) the FIR cannot play the reference turbine's 4x stream")
        for (r, pool, n), (f, met) in builds.items():
            if any(x is not None for x in f):
                ax.plot([r], [n], "k*" if met == len(f) else "rx", ms=11)
        ax.plot([], [], "k*", ms=11, label="built, timing met on every seed")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(rates, [f"{r:g}" for r in rates])
        ax.set_xlabel("RTS sample rate (MS/s)")
        ax.set_ylabel("turbines replayed at once")
        ax.set_title(f"Turbines per {DEVICE}: resource bound (lines) and builds (stars)\n"
                     "reference turbine: NREL 5-MW face-on at 2.8 GHz", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        args.plot.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
