"""The fmax / resource ladder of the replay block on the LFE5U-85F-6 (ULX3S).

Builds each configuration with the open toolchain (one nextpnr at a time)
into ``build/bench_bitstream/<label>/seed<S>/`` and prints one row per build:
requested clock, nextpnr seed, achieved fmax, timing met, LUTs, FFs, DSPs,
block RAMs, and what limits it (the critical path's end points). ``--reuse``
reads reports already built instead of building again; ``--only LABEL``
builds one rung; ``--seeds 1 2 3`` builds each rung at each seed (a rung
meets its clock when every seed does).

    .venv/bin/python bench/bench_bitstream.py [--reuse] [--only n16_100_200] [--seeds 1 2 3] [--late 30]

``--late K`` also lists, from nextpnr's detailed timing report, the K signals
whose endpoints the data reaches latest after the asked clock period: the
whole picture of what misses the clock, where the build's critical path is
only its worst path.

``--readme`` writes the README's timing table (between its
``<!-- timing-table -->`` markers) from the reports of the rungs in
README_ROWS at their seeds: one row per build, every seed's fmax, the worst
seed's margin over the asked clock, the resources and the netlist (the
commit it was made from and its RTLIL digest). A seed whose report is of
another netlist than the current source's is built again; the others are
read. ``make timing-table`` runs it.
"""

import argparse
import json
import time
from pathlib import Path

from rast.gateware.build import NAME, BuildConfig, build, late_endpoints, netlist_identity
from rast.model.contract.fixedpoint import ReplayContract

#: label -> (what it answers, BuildConfig keyword arguments). Every rung on the
#: full board top (PLL, I/O, UART bridge, engine), delays 8190 + 2046 samples.
LADDER = {
    "n64_20_160": ("the default (`make bitstream`): 64 FIR channels at 20 MS/s on a 160 MHz fabric "
                   "(M = 8, 8 pipelines), 65,536-word pool", dict()),
    "n64s_20_160": ("the default with the antenna scan (`--scan`): ACP/ARP inputs, per-channel AZIMUTH, "
                    "a pattern table and gain multiplier per pipeline", dict(scan=True)),
    "f64_2p5_160": ("channels that follow the beam on a 160 MHz fabric (`--clock-mhz 160`): 64 FIR channels "
                    "at 2.5 MS/s as one pipeline of M = 64, streams in SDRAM, a 4,096-row turbine table: "
                    "not met (docs/beam_following.md)",
                    dict(sample_rate_mhz=2.5, clock_mhz=160, pool="sdram", scan=True, follow_rows=4096)),
    "f64_2p5_80": ("channels that follow the beam (`--sample-rate-mhz 2.5 --sdram --scan --follow 4096`, "
                   "its default clock): 64 FIR channels at 2.5 MS/s on an 80 MHz fabric (two pipelines of "
                   "M = 32), streams in SDRAM, a 4,096-row turbine table (docs/beam_following.md)",
                   dict(sample_rate_mhz=2.5, pool="sdram", scan=True, follow_rows=4096)),
    "n64_20_200": ("64 FIR channels at 20 MS/s on a 200 MHz fabric (M = 10, 7 pipelines), 81,920-word "
                   "pool: the withdrawn target", dict(clock_mhz=200, pool_words=81920)),
    "n16_100_200": ("wide band: 16 FIR channels at 100 MS/s on 200 MHz (M = 2, 8 pipelines)",
                    dict(channels=16, sample_rate_mhz=100, clock_mhz=200, pool_words=32768)),
    "n20_20_200": ("two pipelines of the default (20 channels, M = 10), 16,384-word pool",
                   dict(clock_mhz=200, channels=20, pool_words=16384)),
    "n10_20_200": ("one pipeline of the default (10 channels, M = 10), 16,384-word pool",
                   dict(clock_mhz=200, channels=10, pool_words=16384)),
    "n10p_20_200": ("one pipeline of the 200 MHz rung with the default's 65,536-word pool (four banks)",
                    dict(clock_mhz=200, channels=10)),
    "n20p_20_200": ("two pipelines of the default with its whole pool: how fmax falls with the pipelines",
                    dict(clock_mhz=200, channels=20)),
    "n40p_20_200": ("four pipelines of the default with its whole pool", dict(clock_mhz=200, channels=40)),
    "n10_10_100": ("one pipeline at 100 MHz (10 channels at 10 MS/s, M = 10): the CI build",
                   dict(channels=10, sample_rate_mhz=10, clock_mhz=100, pool_words=16384)),
    "s64_20_200": ("streams in SDRAM: the --sdram default, 64 channels at 20 MS/s on 200 MHz (M = 10, "
                   "7 pipelines)", dict(clock_mhz=200, pool="sdram")),
    "s64_20_160": ("streams in SDRAM: 64 channels at 20 MS/s on a 160 MHz fabric (M = 8, 8 pipelines)",
                   dict(pool="sdram")),
    "s32_20_200": ("streams in SDRAM: 32 channels at 20 MS/s on 200 MHz (M = 10, 4 pipelines)",
                   dict(clock_mhz=200, channels=32, pool="sdram")),
    "s32_20_160": ("streams in SDRAM: 32 channels at 20 MS/s on a 160 MHz fabric (M = 8, 4 pipelines)",
                   dict(channels=32, pool="sdram", clock_mhz=160)),
    "s48_20_160": ("streams in SDRAM: 48 channels at 20 MS/s on a 160 MHz fabric (M = 8, 6 pipelines)",
                   dict(channels=48, pool="sdram", clock_mhz=160)),
    "s16_100_200": ("streams in SDRAM: 16 channels at 100 MS/s on 200 MHz (M = 2, 8 pipelines)",
                    dict(clock_mhz=200, channels=16, sample_rate_mhz=100, pool="sdram")),
    "s10_10_100": ("streams in SDRAM: the CI shape at 100 MHz (10 channels at 10 MS/s)",
                   dict(channels=10, sample_rate_mhz=10, clock_mhz=100, pool="sdram")),
}

REPO = Path(__file__).resolve().parent.parent
ROOT = REPO / "build" / "bench_bitstream"

#: The README's timing table: rung -> the nextpnr seeds it is built at. The
#: default and the 64-channel SDRAM build must meet on five of five seeds,
#: the worst at least MARGIN above the asked clock, and so must the default
#: with the antenna scan in; the wide-band build on three; the CI build is
#: the one the test suite places and routes.
README_ROWS = {"n64_20_160": (1, 2, 3, 4, 5), "n64s_20_160": (1, 2, 3, 4, 5), "s64_20_160": (1, 2, 3, 4, 5),
               "n16_100_200": (1, 2, 3), "f64_2p5_80": (1, 2, 3), "n10_10_100": (1,)}
#: Fabric-clock margin over the asked clock the README's rows are held to.
MARGIN = 0.05
TABLE_BEGIN, TABLE_END = "<!-- timing-table:begin -->", "<!-- timing-table:end -->"


def command_of(kw) -> str:
    """The command line that builds the rung of BuildConfig keywords ``kw``:
    ``make bitstream`` for the default, else ``rast build`` with the options
    that differ from the defaults."""
    if not kw:
        return "make bitstream"
    flags = {"channels": "--channels", "sample_rate_mhz": "--sample-rate-mhz", "clock_mhz": "--clock-mhz",
             "pool_words": "--pool-words", "max_delay": "--max-delay", "max_tap": "--max-tap",
             "interpolation": "--interpolation", "cmult_form": "--cmult-form"}
    out = ["rast build"]
    for key, value in kw.items():
        if key == "pool":
            out.append("--sdram" if value == "sdram" else "")
        elif key == "scan":
            out.append("--scan" if value else "")
        elif key == "follow_rows":
            out.append(f"--follow {value}" if value else "")
        else:
            out.append(f"{flags[key]} {value:g}" if isinstance(value, float) else f"{flags[key]} {value}")
    return " ".join(x for x in out if x)


def current_netlist(label, kw) -> dict:
    """The netlist identity of rung ``label`` as the source makes it now
    (elaborated into the rung's folder, no tool run: the seed is no part of it)."""
    out = ROOT / label / "elaborated"
    build(BuildConfig(**kw), out, quiet=True, run_tools=False)
    return netlist_identity(out)


def build_name(cfg: BuildConfig) -> str:
    """A build's name in the README's table, from its configuration (the
    default's in bold)."""
    c = cfg.contract()
    name = (f"{c.channels} ch{' from SDRAM' if cfg.pool == 'sdram' else ''}, {cfg.sample_rate_mhz:g} MS/s, "
            f"{cfg.clock_mhz:g} MHz (M = {c.slots}, {c.pipelines} pipelines), pool {cfg.pool_words:,} words"
            + (", antenna scan" if cfg.scan else ""))
    return f"**the default: {name}**" if cfg == BuildConfig() else name


def table_row(label, seeds, reports) -> str:
    """One row of the README's timing table from the rung's reports (one per
    seed; None for a seed not built of the current netlist)."""
    what, kw = LADDER[label]
    cfg = BuildConfig(**kw)
    asked = cfg.clock_mhz
    built = [r for r in reports if r is not None]
    if not built:
        return (f"| {build_name(cfg)} | `{command_of(kw)}` | seeds {'/'.join(map(str, seeds))}: not built of "
                "this netlist | - | - | - |")
    fmax = [r["timing"]["fmax_mhz"] for r in built]
    met = [r["timing"]["met"] for r in built]
    worst = min(fmax) / asked - 1
    res = built[0]["resources"]
    used = ", ".join(f"{res[k]['used']:,} {name}" for k, name in (("luts", "LUT"), ("ffs", "FF"),
                                                                  ("dsps", "DSP"), ("block_rams", "DP16KD")))
    controller = [r["timing"]["domains"].get("sdram", {}).get("achieved_mhz") for r in built]
    extra = (f"; controller {min(controller):.1f}-{max(controller):.1f} MHz (50)"
             if all(controller) and cfg.pool == "sdram" else "")
    commits = sorted({r["netlist"]["commit"] or "?" for r in built})
    digests = sorted({r["netlist"]["rtlil_sha256"][:12] for r in built})
    name = build_name(cfg)
    verdict = (f"**{sum(met)} of {len(met)}**" + (f", worst +{100 * worst:.1f} %" if all(met) else "")
               + (f" ({len(reports) - len(built)} seed(s) not built)" if len(built) < len(reports) else ""))
    by_seed = " / ".join("not built" if r is None else f"{r['timing']['fmax_mhz']:.1f}" for r in reports)
    return (f"| {name} | `{command_of(kw)}` | seeds {'/'.join(map(str, seeds))}: {by_seed}{extra} | "
            f"{verdict} | {used} | {', '.join(f'`{x}`' for x in commits)} (RTLIL {', '.join(digests)}) |")


def write_readme_table(rows: dict, readme=REPO / "README.md") -> str:
    """Replace the README's timing table with ``rows`` (label -> row text)."""
    head = ("| build | command | fabric MHz by nextpnr seed (asked: the build's clock) | met "
            "(worst seed's margin) | resources | netlist |\n| --- | --- | --- | --- | --- | --- |\n")
    table = head + "\n".join(rows.values()) + "\n"
    text = readme.read_text()
    if TABLE_BEGIN not in text or TABLE_END not in text:
        raise SystemExit(f"{readme} has no {TABLE_BEGIN} ... {TABLE_END} markers")
    before, rest = text.split(TABLE_BEGIN, 1)
    after = rest.split(TABLE_END, 1)[1]
    readme.write_text(f"{before}{TABLE_BEGIN}\n{table}{TABLE_END}{after}")
    return table


def readme_table(rebuild_stale=True):
    """Every README_ROWS rung at its seeds: reports of the current netlist
    read, the others built again; then the README's table written."""
    rows = {}
    for label, seeds in README_ROWS.items():
        what, kw = LADDER[label]
        reports = []
        now = current_netlist(label, kw)
        for seed in seeds:
            out = ROOT / label / f"seed{seed}"
            rp = out / "report.json"
            old = json.loads(rp.read_text()) if rp.exists() else None
            if old is None or "timing" not in old or old.get("netlist", {}).get("rtlil_sha256") != now["rtlil_sha256"]:
                if not rebuild_stale:
                    print(f"{label} seed {seed}: no report of the current netlist in {out}", flush=True)
                    reports.append(None)
                    continue
                t0 = time.monotonic()
                build(BuildConfig(**kw, seed=seed), out, quiet=True)
                print(f"built {label} seed {seed} in {time.monotonic() - t0:.0f} s", flush=True)
                old = json.loads(rp.read_text())
            reports.append(old)
            print(row(label, what, old), flush=True)
        rows[label] = table_row(label, seeds, reports)
    print(write_readme_table(rows))


def row(label, what, rep):
    t, r = rep["timing"], rep["resources"]
    cp = t.get("critical_path") or {}
    lim = f"{cp.get('from', '?')} -> {cp.get('to', '?')} ({cp.get('routing_ns', 0):.1f} of " \
          f"{cp.get('delay_ns', 0):.1f} ns routing)"
    return (f"{label:<12} {rep['config']['channels']:>3} {rep['build']['sample_rate_hz'] / 1e6:>5.0f} "
            f"{rep['build']['slots']:>3} {rep['config']['pool_words']:>6} "
            f"{rep['config']['clock_mhz']:>6.0f} {rep['config']['seed']:>4} {t['fmax_mhz']:>7.1f} {'yes' if t['met'] else 'NO':>4} "
            f"{r['luts']['used']:>6} {r['ffs']['used']:>6} {r['dsps']['used']:>4}/{r['dsps']['available']} "
            f"{r['block_rams']['used']:>4}/{r['block_rams']['available']}  {lim}\n"
            f"{'':<12} {what}")


def seed_capacity():
    """Turbines one LFE5U-85F replays at once from block RAM alone at the
    default build's slots and delays (20 MS/s on 200 MHz, 8190 + 2046
    samples, FIR): the seed's section 4.3 turbines (stream rate 4 x max
    Doppler, C band), each alone many times over, with room to reload one
    while all play; and the 64-turbine example farm as it is."""
    from rast.gateware.capacity import pool_words_for, total_blocks, total_dsps, turbines_per_device, \
        DEVICE_BLOCKS
    from rast.model.physics.farm import load_config
    from rast.model.physics.stream import build_farm_streams
    examples = Path(__file__).resolve().parent.parent / "examples"
    kw = BuildConfig().replay_kwargs()
    shape = dict(slots=kw["slots"], max_delay=kw["max_delay"], max_tap=kw["max_tap"])
    print(f"\nturbines per LFE5U-85F from block RAM (the default build's M = {shape['slots']}, delays "
          f"{shape['max_delay']} + {shape['max_tap']}; every stream in the pool with room to reload one):")
    for name in ("sec4_3_3_three_blades", "sec4_3_3_realistic", "sec4_3_4_four_windmills",
                 "two_windmills"):
        farm = load_config(examples / f"{name}.toml")
        for s in build_farm_streams(farm).streams:
            words = s.plan.length
            n, pool, lim = turbines_per_device(words, **shape)
            print(f"  {name:<24} {s.windmill.name:<5} {s.windmill.rpm:>3g} rpm "
                  f"{s.windmill.num_blades} blade(s) {s.plan.max_doppler_hz:>6.0f} Hz "
                  f"{words:>6} words: {n:>3} turbines, pool {pool} words (one more: {lim})")
    brams, dsps = DEVICE_BLOCKS["LFE5U-85F"]
    for name in ("farm_atc_sband", "farm_layout"):
        farm = load_config(examples / f"{name}.toml")
        lengths = [s.plan.length for s in build_farm_streams(farm).streams]
        pool = pool_words_for(sum(lengths) + max(lengths))
        c = ReplayContract(channels=len(lengths), pool_words=pool, **shape)
        fits = total_blocks(c) <= brams and total_dsps(c) <= dsps
        print(f"  {name:<24} {len(lengths)} turbines, {sum(lengths)} words (longest {max(lengths)}): "
              f"pool {pool} words, {total_blocks(c)}/{brams} DP16KD, {total_dsps(c)}/{dsps} DSP: "
              f"{'all fit' if fits else 'does not fit'}")


def print_late(out, rep, k):
    """The signals whose endpoints miss the asked fabric clock (late_endpoints)."""
    t = rep["timing"]
    clock = t["fabric_clock"]
    period = 1e3 / rep["config"]["clock_mhz"]
    nextpnr = json.loads((out / f"{NAME}.report.json").read_text())
    if "detailed_net_timings" not in nextpnr:
        print(f"{'':<12} (no detailed timing in this build: build it again with --late)")
        return
    late = late_endpoints(nextpnr, clock, period)
    total = sum(n for _, n, _ in late)
    print(f"{'':<12} {total} endpoints reached more than {period:.2f} ns after the clock, "
          f"in {len(late)} signals; the {min(k, len(late))} latest:")
    for name, n, arrival in late[:k]:
        print(f"{'':<14} {arrival:6.2f} ns  {n:5d}  {name}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reuse", action="store_true", help="print reports already built")
    ap.add_argument("--only", action="append", choices=sorted(LADDER), help="build only these rungs")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1], metavar="S",
                    help="nextpnr seeds to build each rung at (default: 1)")
    ap.add_argument("--capacity", action="store_true", help="only print the turbines-per-device table")
    ap.add_argument("--readme", action="store_true",
                    help="write the README's timing table (README_ROWS at their seeds; stale or missing "
                         "reports built again)")
    ap.add_argument("--no-build", action="store_true",
                    help="with --readme: build nothing; seeds without a report of the current netlist "
                         "are shown as not built")
    ap.add_argument("--late", type=int, metavar="K", default=0,
                    help="build with nextpnr's detailed timing report and list the K signals whose "
                         "endpoints miss the asked clock by the most (all endpoints counted)")
    args = ap.parse_args()
    if args.capacity:
        seed_capacity()
        return
    if args.readme:
        readme_table(rebuild_stale=not args.no_build)
        return
    print(f"{'label':<12} {'N':>3} {'fs':>5} {'M':>3} {'pool':>6} {'fclk':>6} {'seed':>4} {'fmax':>7} {'met':>4} {'LUTs':>6} "
          f"{'FFs':>6} {'DSPs':>8} {'BRAMs':>8}  critical path")
    for label, (what, kw) in LADDER.items():
        if args.only and label not in args.only:
            continue
        met = []
        for seed in args.seeds:
            out = ROOT / label / f"seed{seed}"
            rp = out / "report.json"
            note = what
            if not (args.reuse and rp.exists()):
                t0 = time.monotonic()
                extra = ["--detailed-timing-report"] if args.late else []
                build(BuildConfig(**kw, seed=seed, extra_nextpnr=extra), out, quiet=True)
                note += f" (built in {time.monotonic() - t0:.0f} s)"
            rep = json.loads(rp.read_text())
            met.append(rep["timing"]["met"])
            print(row(label, note, rep), flush=True)
            if args.late:
                print_late(out, rep, args.late)
        if len(args.seeds) > 1:
            print(f"{'':<12} {label}: timing met at {sum(met)} of {len(met)} seeds", flush=True)
    seed_capacity()


if __name__ == "__main__":
    main()
