"""cocotb end-to-end test: a farm config's radar time line through the RTL and a radar receiver.

Parameters (``RAST_TB_PARAMS``): ``config``, ``seconds``, optional
``channels``, ``overlap``, ``preload`` (and ``damage_image``: bit 14 of the
first preloaded beat flipped, which the comparison must catch). Writes ``e2e.npz`` (per-pulse samples of RTL and
model, spectrograms) and ``e2e.json`` (figures and checks, the PRF, the
gates' ranges and the SFDR of the RTL's samples per gate) to the run
directory; fails on the first mismatching sample, on spectrograms that are
not identical, or on a windmill whose maximum Doppler in the RTL spectrogram
is more than one Doppler bin from the physics.
"""

from __future__ import annotations

import time

import cocotb
import numpy as np

from rast.model.radar.receiver import spectrogram
from rast.sim import bulk
from rast.sim.e2e import doppler_aliased, doppler_check, gate_sfdr, prepare, receiver, save_json
from rast.sim.scenario import ModelBeside
from rast.sim.tb_top import check_bulk_run, check_sdram_flags
from rast.sim.testbench import BulkBench, Scoreboard, params, run_dir


@cocotb.test()
async def e2e(dut):
    p = params()
    d = run_dir()
    t0 = time.monotonic()
    e = prepare(p["config"], p["seconds"], channels=p.get("channels"), slots=p.get("slots", 1),
                pool=p.get("pool", "bram"), reload_s=p.get("reload_s"), noise_rms=p.get("noise_rms", 0.0),
                preload=p.get("preload", False))
    if p.get("damage_image"):
        name, (index, values) = next(iter(e.scenario.job.images.items()))
        e.scenario.job.images[name] = (index, np.concatenate([values[:1] ^ 0x4000, values[1:]]))
    t_prep = time.monotonic() - t0
    cocotb.log.info("e2e %s: %s", e.scenario.name, e.info)
    beside = ModelBeside(e.scenario, d)          # the model on the other core, during the RTL run
    summary = await BulkBench(dut).run(e.scenario.job, progress=True)
    t1 = time.monotonic()
    expected = beside.result()
    t_model = time.monotonic() - t1               # the wait for the model after the RTL run
    if e.scenario.contract.pool == "sdram":
        check_sdram_flags(e.scenario.name, summary)           # before the samples: a late word says why
    # a quarter of each pulse's samples echoed, on average: an S-band radar's
    # 1 us pulse every 1 ms leaves 0.1 % of the samples non-zero per turbine
    rep = check_bulk_run(e.scenario, summary, expected=expected,
                         overflow_observed=summary.get("obs_overflow"),
                         min_active=e.pulse.n_pulses * max(1, e.pulse.pulse_samples // 4))
    _, idx, gi, gq = bulk.read_outputs(d)
    yi, yq, _ = expected
    rtl = receiver(e, idx, gi, gq)
    mdl = receiver(e, idx, yi[idx], yq[idx])
    r = e.farm.radar
    overlap = float(p.get("overlap", 0.9))
    cpi_pulses = int(round(r.cpi_ms * 1e-3 * r.prf_hz))
    sb = Scoreboard(e.scenario.name)
    if e.pulse.n_pulses >= cpi_pulses:
        spec_rtl = [spectrogram(row, r.prf_hz, r.cpi_ms * 1e-3, overlap=overlap) for row in rtl]
        spec_mdl = [spectrogram(row, r.prf_hz, r.cpi_ms * 1e-3, overlap=overlap) for row in mdl]
        spectra_equal = [bool(np.array_equal(a.power_db, b.power_db)) for a, b in zip(spec_rtl, spec_mdl)]
        for g, equal in enumerate(spectra_equal):
            if not equal:
                sb._fail(f"range gate {g}: RTL and model spectrograms differ although their samples are equal")
        checks = doppler_check(e, spec_rtl)
        extra = dict(times_s=spec_rtl[0].times_s, doppler_hz=spec_rtl[0].doppler_hz,
                     **{f"power_rtl_{g}": s.power_db for g, s in enumerate(spec_rtl)},
                     **{f"power_model_{g}": s.power_db for g, s in enumerate(spec_mdl)})
    else:
        cocotb.log.warning("%d pulses are less than one CPI (%d): no spectrogram", e.pulse.n_pulses, cpi_pulses)
        checks, extra, spectra_equal = [], {}, []
    np.savez_compressed(d / "e2e.npz", rtl=rtl, model=mdl, gates=np.array([g[0] for g in e.gates]), **extra)
    report = dict(rep, config=e.config, seconds=p["seconds"], info=e.info, overlap=overlap,
                  prepare_s=t_prep, model_s=t_model, rtl_wall_s=summary["wall_s"], rtl_cpu_s=summary["cpu_s"],
                  prf_hz=r.prf_hz,
                  gates_km=[rk for _, rk, _ in e.gates],
                  gates=[dict(offset=o, range_km=rk, windmills=[e.farm.windmills[i].name for i in m])
                         for o, rk, m in e.gates],
                  doppler=checks, spectrograms_equal=all(spectra_equal) if checks else None,
                  # a reload switches every channel at once: its stream restarts from its
                  # first word, so the rotation jumps and the physics' track no longer holds;
                  # a turning antenna lights each turbine only while the beam is on it;
                  # a Doppler beyond ±PRF/2 aliases, and a gate's outermost line is then
                  # not its turbines' maximum (an S-band turbine under a 1 kHz PRF)
                  doppler_checked=(p.get("reload_s") is None and not e.farm.scan.turning
                                   and not doppler_aliased(e)),
                  **gate_sfdr(e, rtl))
    save_json(d / "e2e.json", report)
    for c in checks:
        cocotb.log.info("%s: max Doppler RTL %.1f Hz, physics %.1f Hz (bin %.1f Hz) %s", c["windmill"],
                        c["measured_hz"], c["physics_hz"], c["bin_hz"],
                        "ok" if c["ok"] else ("FAIL" if c["reached"] else "peak not in this run"))
    if not report["doppler_checked"]:
        return
    bad = [c for c in checks if not c["ok"]]
    unreached = [c["windmill"] for c in checks if not c["reached"]]
    if unreached and p.get("require_peaks", True):
        sb._fail(f"the run never shows the maximum Doppler of {', '.join(unreached)}: "
                 "simulate more radar time")
    bad = [c for c in bad if c["reached"]]
    if bad:
        sb._fail("maximum Doppler off by more than one bin: " + "; ".join(
            f"{c['windmill']}: RTL {c['measured_hz']:.1f} Hz, physics {c['physics_hz']:.1f} Hz "
            f"(bin {c['bin_hz']:.1f} Hz, frame at {c['frame_time_s']:.3f} s)" for c in bad))


@cocotb.test()
async def bench(dut):
    """Only the RTL run of the e2e job (no model): the benchmark's cosim figure."""
    p = params()
    e = prepare(p["config"], p["seconds"], channels=p.get("channels"), slots=p.get("slots", 1),
                pool=p.get("pool", "bram"), reload_s=p.get("reload_s"), preload=p.get("preload", False))
    summary = await BulkBench(dut).run(e.scenario.job, progress=True)
    save_json(run_dir() / "bench.json", dict(summary, info=e.info))
