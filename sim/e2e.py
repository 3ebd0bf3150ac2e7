"""End to end: a farm config, sampled radar pulses through the RTL, a radar receiver.

:func:`prepare` turns a config into a bulk :class:`~rast.sim.scenario.Scenario`:
the golden model's streams, delays and gains (``rast.model.stream``) loaded
by ``manifest_to_register_writes`` at sample 0, and ``seconds`` of radar time
of sampled pulses (:mod:`rast.model.pulses`, seed Table 4.1's chirp where the
sample rate allows it). Every RTS sample of that time line goes through the
DUT (the stream phase advances per sample, so idle time cannot be skipped);
only each pulse's own samples cross the file boundary, the wrapper fills the
idle time with zeros.

The radar receiver keeps one sample per pulse at each range gate, i.e. at
each distinct windmill delay plus half a pulse (the middle of the echo), and
computes the micro-Doppler spectrogram (``rast.model.radar.spectrogram``) of
the RTL's samples and of the model's. :func:`doppler_check` compares each
windmill's maximum Doppler in the RTL spectrogram with the physics.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rast.model.fixedpoint import ReplayContract
from rast.model.pulses import PulseConfig, generate
from rast.model.loadplan import manifest_to_register_writes

from .bulk import MAX_CAP, BulkJob
from .scenario import Scenario

__all__ = ["E2E", "prepare", "contract_for", "receiver", "doppler_check", "physics_doppler_track",
           "gate_windmills", "gate_sfdr"]


@dataclass
class E2E:
    config: str
    farm: object
    streams: object
    scenario: Scenario
    pulse: PulseConfig
    gates: list                     # [(offset in PRI, range_km, [windmill indices])]
    info: dict = field(default_factory=dict)


def contract_for(farm_streams, channels: int | None = None, slots: int = 1) -> ReplayContract:
    """The smallest replay block the farm fits, with ``slots`` channels per
    pipeline (sample rate not stated: it changes no integer, and one build
    serves every rate)."""
    return dataclasses.replace(farm_streams.smallest_contract(channels), slots=slots, sample_rate_hz=0)


def prepare(config, seconds: float = 1.0, *, channels: int | None = None, slots: int = 1,
            amplitude: float = 0.4,
            noise_rms: float = 0.0, seed: int = 1, gap_thresh: int = 4, stall_thresh: int = 4) -> E2E:
    from rast.model.config import load_config
    from rast.model.stream import build_farm_streams
    farm = load_config(config)
    fs = build_farm_streams(farm)
    manifest = fs.manifest()
    c = contract_for(fs, channels, slots)
    writes = manifest_to_register_writes(manifest, c, streams=[s.words for s in fs.streams])
    r = farm.radar
    bw = min(20.0, farm.sample_rate_mhz)          # Table 4.1: 20 MHz linear chirp up
    pulse = PulseConfig.for_seconds(seconds, sample_rate_mhz=farm.sample_rate_mhz, prf_hz=r.prf_hz,
                                    pulse_width_us=r.pulse_width_us, shape="chirp", bandwidth_mhz=bw,
                                    amplitude=amplitude, noise_rms=noise_rms, seed=seed,
                                    noise_in_pulse_only=True)
    active = pulse.pulse_samples
    train = generate(pulse, active_samples=active)
    gates = {}
    for k, s in enumerate(fs.streams):
        off = s.delay_samples + active // 2
        if off >= pulse.samples_per_pri:
            raise ValueError(f"windmill {s.windmill.name!r}: its echo ({s.delay_samples} samples) "
                             f"lies beyond the PRI ({pulse.samples_per_pri} samples)")
        gates.setdefault(off, (s.windmill.range_km, []))[1].append(farm.windmills.index(s.windmill))
    gate_list = [(off, rk, members) for off, (rk, members) in sorted(gates.items())]
    if len(gate_list) > MAX_CAP:
        raise ValueError(f"at most {MAX_CAP} distinct windmill ranges, not {len(gate_list)}")
    max_total_delay = max(s.delay_samples for s in fs.streams)
    job = BulkJob(src=train.words(), active=active, pri=pulse.samples_per_pri, pulses=pulse.n_pulses,
                  flush=max(0, max_total_delay + active - pulse.samples_per_pri) + 8,
                  regs=[(0, a, v) for a, v in writes], gap_thresh=gap_thresh, gap_max=3,
                  stall_thresh=stall_thresh, seed=seed, cap_offsets=tuple(g[0] for g in gate_list),
                  timeout=10_000)
    sc = Scenario(f"e2e-{Path(config).stem}-{seconds:g}s", c, job, farm.sample_rate_hz)
    return E2E(str(config), farm, fs, sc, pulse, gate_list,
               info=dict(channels=c.channels, slots=c.slots, pool_words=c.pool_words, max_delay=c.max_delay,
                         max_tap=c.max_tap, latency=c.latency, pulses=pulse.n_pulses,
                         samples=job.n_in, samples_per_pri=pulse.samples_per_pri, active=active))


def receiver(e: E2E, index: np.ndarray, i: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per-pulse complex samples, shape (gates, pulses), from captured outputs.

    ``index`` is each captured sample's position in the output sequence.
    """
    pri = e.pulse.samples_per_pri
    out = np.zeros((len(e.gates), e.pulse.n_pulses), dtype=complex)
    pulse = index // pri
    off = index % pri
    ok = pulse < e.pulse.n_pulses
    for g, (o, _, _) in enumerate(e.gates):
        sel = ok & (off == o)
        out[g, pulse[sel]] = i[sel] + 1j * q[sel]
    return out


def gate_windmills(e: E2E, g: int) -> list[int]:
    """Windmills whose echo is being received at gate ``g``'s sample (eq. 2.3):
    those of the gate and any other whose delayed pulse covers its offset."""
    off = e.gates[g][0]
    active = e.pulse.pulse_samples
    inside = {e.farm.windmills.index(s.windmill) for s in e.streams.streams
              if s.delay_samples <= off < s.delay_samples + active}
    return sorted(inside | set(e.gates[g][2]))


def gate_sfdr(e: E2E, samples: np.ndarray) -> dict:
    """SFDR (:mod:`rast.model.sfdr`) of per-pulse samples of shape (gates, pulses), per gate and the worst.

    Each gate excludes the largest maximum Doppler of the windmills received at
    its sample. Returns ``{}`` with less than one CPI of pulses, and
    ``sfdr_db: None`` with the reason in ``sfdr_error`` when the turbines'
    band leaves nothing to measure; an SFDR with no line at all outside the
    band (+inf) is reported as ``None`` too.
    """
    from rast.model.radar import RangeBin
    from rast.model.sfdr import farm_sfdr
    r = e.farm.radar
    if samples.shape[1] < int(round(r.cpi_ms * 1e-3 * r.prf_hz)):
        return {}
    bins = [RangeBin(rk, tuple(gate_windmills(e, g))) for g, (_, rk, _) in enumerate(e.gates)]
    try:
        res = farm_sfdr(e.farm, samples, bins)
    except ValueError as error:
        return dict(sfdr_db=None, sfdr_error=str(error), sfdr=[])
    finite = lambda x: float(x) if np.isfinite(x) else None  # noqa: E731
    per = [dict(gate=g, offset=e.gates[g][0], range_km=b.range_km, sfdr_db=finite(x.sfdr_db),
                spur_hz=x.spur_hz, cpi=x.cpi_index, cpis=int(x.per_cpi_db.size),
                windmills=[e.farm.windmills[i].name for i in b.members])
           for g, (b, x) in enumerate(zip(bins, res))]
    k = min(range(len(res)), key=lambda i: res[i].sfdr_db)
    return dict(sfdr_db=finite(res[k].sfdr_db), sfdr_worst_gate=k, sfdr=per)


def _scatterer_dopplers(windmill, wavelength_m: float, t_s: np.ndarray) -> np.ndarray:
    """Instantaneous Doppler (Hz) of every blade's every scatterer at t, shape
    (blades × scatterers, T): ``f = 2·ω·r·cos(rotor)·cos(β_b(t))/λ``, the
    derivative of φ = −4πΔR/λ."""
    from rast.model.turbine import blade_angles
    omega = 2 * np.pi * windmill.rpm / 60.0
    beta = blade_angles(windmill, t_s)                                  # (blades, T)
    r = np.asarray(windmill.radius_m, dtype=float)[:, None, None]       # (rcs, 1, 1)
    f = 2 * omega * r * np.cos(np.deg2rad(windmill.rotor_angle_deg)) * np.cos(beta)[None] / wavelength_m
    return f.reshape(-1, len(t_s))


def physics_doppler_track(windmill, wavelength_m: float, t_s: np.ndarray) -> np.ndarray:
    """The instantaneous Doppler of largest magnitude over the windmill's blades and
    scatterers at t (signed). Its extreme is the windmill's maximum Doppler
    (seed 4.3.3: 1460 Hz and 1870 Hz), reached on either side of zero."""
    f = _scatterer_dopplers(windmill, wavelength_m, t_s)
    return f[np.argmax(np.abs(f), axis=0), np.arange(len(t_s))]


def doppler_check(e: E2E, spectra: list, *, edge_db: float = 6.0) -> list[dict]:
    """For each windmill: the frame where its physical Doppler peaks, the RTL
    spectrogram's Doppler edge in that frame (the bin farthest out on the
    physics' side, over the whole band, within ``edge_db`` of the frame's
    strongest line), and the physics it is checked against (Hz), with the bin
    width. Searching the whole band, not a window around the expected value,
    lets a misplaced or missing signature fail. 6 dB: the Hann window's main
    lobe is 6 dB down one bin from its centre, so the edge of a line lies
    within a bin of it.

    Windmills that share a range gate share its spectrogram, and which of
    their lines is within ``edge_db`` of the strongest depends on their
    strengths in that frame. There the edge must be explained by one of the
    gate's windmills: within a bin of the span its Doppler covers in that
    frame, from its value at the frame's centre to the farthest it reaches
    during the frame (``physics_hz``: that windmill's nearest value;
    ``explained_by``: its name; ``windmill_hz``: this windmill's own value at
    the centre). Alone in its gate a windmill explains its own edge, and at
    its peak its Doppler stands still, so the span is one value. In a shared
    gate the check is looser (a fast windmill's Doppler can sweep hundreds of
    Hz during one CPI) but still fails an edge that no windmill of the gate
    can produce: a wrong rate, scale or sign, a missing signature."""
    from rast.model.turbine import max_doppler_hz
    farm = e.farm
    lam = farm.radar.wavelength_m
    out = []
    for g, (_, rk, members) in enumerate(e.gates):
        spec = spectra[g]
        res = spec.resolution_hz
        cpi_s = 1.0 / res
        for wi in members:
            w = farm.windmills[wi]
            track = physics_doppler_track(w, lam, spec.times_s)
            j = int(np.argmax(np.abs(track)))
            own = float(track[j])
            side_sign = 1.0 if own >= 0 else -1.0
            frame = spec.power_db[j]
            strong = np.nonzero(frame >= frame.max() - edge_db)[0]
            side = strong[np.sign(spec.doppler_hz[strong]) == side_sign]
            measured = (float(spec.doppler_hz[side[np.argmax(np.abs(spec.doppler_hz[side]))]])
                        if side.size else 0.0)
            # each member's span on this side during the frame: |centre| .. farthest
            # (an odd number of instants: the middle one is the frame's centre)
            during = np.linspace(spec.times_s[j] - cpi_s / 2, spec.times_s[j] + cpi_s / 2, 129)
            best = None
            for mi in [wi] + [k for k in members if k != wi]:
                m = farm.windmills[mi]
                on_side = (side_sign * _scatterer_dopplers(m, lam, during)).max(axis=0)
                centre = max(float(on_side[during.size // 2]), 0.0)
                far = max(float(on_side.max()), centre)
                if far <= res:
                    continue            # no line of this windmill on this side in this frame
                nearest = side_sign * min(max(side_sign * measured, centre), far)
                # this windmill first: another explains the edge only where it does not
                if mi == wi and abs(measured - nearest) <= res:
                    best = (nearest, m.name)
                    break
                if best is None or abs(measured - nearest) < abs(measured - best[0]):
                    best = (nearest, m.name)
            fine = np.linspace(spec.times_s[0], spec.times_s[-1], 20001)
            run_max = float(np.abs(physics_doppler_track(w, lam, fine)).max())
            top = max_doppler_hz(w, lam)
            # the windmill's maximum Doppler is only seen if its peak falls inside the frames
            reached = run_max >= top - res
            best = best or (own, w.name)
            out.append(dict(windmill=w.name, range_km=rk, frame_time_s=float(spec.times_s[j]),
                            physics_hz=best[0], explained_by=best[1], windmill_hz=own,
                            measured_hz=measured, bin_hz=res,
                            physics_run_max_hz=run_max, physics_max_hz=top, reached=bool(reached),
                            ok=bool(reached and abs(measured - best[0]) <= res)))
    return out


def save_json(path, obj):
    Path(path).write_text(json.dumps(obj, indent=2, default=float))
