"""End to end: a farm config, sampled radar pulses through the RTL, a radar receiver.

:func:`prepare` turns a config into a bulk :class:`~rast.sim.scenario.Scenario`:
the golden model's streams, delays and gains (``rast.model.physics.stream``) loaded
by ``manifest_to_register_writes`` at sample 0, and ``seconds`` of radar time
of sampled pulses (:mod:`rast.model.radar.pulses`, seed Table 4.1's chirp where the
sample rate allows it). Every RTS sample of that time line goes through the
DUT (the stream phase advances per sample, so idle time cannot be skipped);
only each pulse's own samples cross the file boundary, the wrapper fills the
idle time with zeros.

The radar receiver keeps one sample per pulse at each range gate, i.e. at
each distinct windmill delay plus half a pulse (the middle of the echo), and
computes the micro-Doppler spectrogram (``rast.model.radar.receiver.spectrogram``) of
the RTL's samples and of the model's. :func:`doppler_check` compares each
windmill's maximum Doppler in the RTL spectrogram with the physics.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rast.model.contract.fixedpoint import ReplayContract, pool_words_for
from rast.model.radar.pulses import PulseConfig, generate
from rast.model.contract.loadplan import manifest_to_register_writes, pool_layout, stream_writes
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP, register_map

from .bulk import MAX_CAP, BulkJob
from .scenario import Scenario

__all__ = ["E2E", "prepare", "contract_for", "receiver", "doppler_aliased", "doppler_check", "physics_doppler_track",
           "gate_windmills", "gate_sfdr", "signature_edge_hz"]


@dataclass
class E2E:
    config: str
    farm: object
    streams: object
    scenario: Scenario
    pulse: PulseConfig
    gates: list                     # [(offset in PRI, range_km, [windmill indices])]
    info: dict = field(default_factory=dict)


def contract_for(farm_streams, channels: int | None = None, slots: int = 1, pool: str = "bram",
                 copies: int = 1) -> ReplayContract:
    """The smallest replay block the farm fits, with ``slots`` channels per
    pipeline (sample rate not stated: it changes no integer, and one build
    serves every rate; the SDRAM bounds then assume the fastest fabric), its
    pool in ``pool`` (an SDRAM pool's words a power of two) and holding
    ``copies`` of every stream (2: a reload beside the streams playing)."""
    c = dataclasses.replace(farm_streams.smallest_contract(channels), slots=slots, sample_rate_hz=0)
    words = sum(s.plan.length for s in farm_streams.streams)
    if pool == "sdram":
        c = dataclasses.replace(c, pool="sdram", pool_words=max(16, 1 << (copies * words - 1).bit_length()))
    elif copies > 1:
        c = dataclasses.replace(c, pool_words=pool_words_for(copies * words))
    return c


#: Register writes of a reload issued together (see :func:`reload_writes`).
RELOAD_GROUP = 64


def reload_writes(farm_streams, c: ReplayContract, at: int, first_base: int) -> list:
    """A reload of every stream while the farm plays: the same words again
    from pool address ``first_base`` on (where nothing plays), each channel
    then switched to its copy at once (disable, SWAP, enable: a stream's
    period is a rotor's third, seconds, longer than a run; the block checks
    its CRC first and mutes the channel while it refills from the pool).
    The writes go RELOAD_GROUP at a time, a group every ``RELOAD_GROUP x
    pool_word_cycles / slots`` samples from sample ``at`` on: the pool takes
    them as fast as they come, and the radar's time line runs on between
    groups (the bulk wrapper holds the input while a write waits, and the
    model steps once per group). Returns ``[(sample, addr, value), ...]``."""
    rmap = register_map(c)
    a = rmap.addr
    lengths = [s.plan.length for s in farm_streams.streams]
    w = []
    for ch, (s, base) in enumerate(zip(farm_streams.streams, pool_layout(lengths, c.pool_words - first_base))):
        w += stream_writes(rmap, ch, first_base + base, list(s.words), s.plan.phase_increment)
        w += [(a("CTRL", ch), 0), (a("CTRL", ch), CTRL_SWAP), (a("CTRL", ch), CTRL_ENABLE)]
    spacing = -(-RELOAD_GROUP * c.pool_word_cycles // c.slots)
    return [(at + k // RELOAD_GROUP * spacing, addr, value) for k, (addr, value) in enumerate(w)]


def prepare(config, seconds: float = 1.0, *, channels: int | None = None, slots: int = 1,
            pool: str = "bram", reload_s: float | None = None, amplitude: float = 0.4,
            noise_rms: float = 0.0, seed: int = 1, gap_thresh: int = 4, stall_thresh: int = 4,
            preload: bool = False) -> E2E:
    """The farm's cosimulation job. ``preload`` (SDRAM pool only): the streams
    are in the simulated SDRAM and every register at its value from power-up
    (``Scenario.inits``; the wrapper loads ``job.images``), instead of the
    load's register writes: a 512-turbine farm's load is 1.65 M stream words,
    80 fabric clocks each through the bus (docs/sdram.md)."""
    from rast.model.contract.loadplan import manifest_channel_inits
    from rast.model.contract.powerup import pool_contents
    from rast.model.physics.farm import load_config
    from rast.model.physics.stream import build_farm_streams
    if preload and (pool != "sdram" or reload_s is not None):
        raise ValueError("preload is for an SDRAM pool without a reload")
    farm = load_config(config)
    fs = build_farm_streams(farm)
    manifest = fs.manifest()
    c = contract_for(fs, channels, slots, pool, copies=1 if reload_s is None else 2)
    streams = [s.words for s in fs.streams]
    inits, common_delay, images = None, 0, {}
    if preload:
        from rast.sim.sdram_top import sdram_image
        inits, common_delay = manifest_channel_inits(manifest, c, streams=streams)
        used = max(ini.base + len(ini.words) for ini in inits)
        images = sdram_image(pool_contents(inits, c.pool_words)[:used])
        writes = []
    else:
        writes = manifest_to_register_writes(manifest, c, streams=streams)
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
    regs = [(0, a, v) for a, v in writes]
    if reload_s is not None:
        at = int(round(reload_s * farm.sample_rate_hz))
        if not 0 < at < pulse.n_pulses * pulse.samples_per_pri:
            raise ValueError(f"the reload at {reload_s:g} s is not inside the run of {seconds:g} s")
        regs += reload_writes(fs, c, at, c.pool_words // 2)
        if regs[-1][0] >= pulse.n_pulses * pulse.samples_per_pri:
            raise ValueError(f"the reload from {reload_s:g} s ends after the run of {seconds:g} s: "
                             "reload earlier or run longer")
    job = BulkJob(src=train.words(), active=active, pri=pulse.samples_per_pri, pulses=pulse.n_pulses,
                  flush=max(0, max_total_delay + active - pulse.samples_per_pri) + 8,
                  regs=regs, gap_thresh=gap_thresh, gap_max=3,
                  stall_thresh=stall_thresh, seed=seed, cap_offsets=tuple(g[0] for g in gate_list),
                  timeout=10_000, images=images)
    sc = Scenario(f"e2e-{Path(config).stem}-{seconds:g}s", c, job, farm.sample_rate_hz, inits, common_delay)
    return E2E(str(config), farm, fs, sc, pulse, gate_list,
               info=dict(channels=c.channels, slots=c.slots, pool=c.pool, pool_words=c.pool_words,
                         reload_s=reload_s, reload_writes=len(regs) - len(writes),
                         reload_end_s=regs[-1][0] / farm.sample_rate_hz if reload_s is not None else None,
                         max_delay=c.max_delay,
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
    """SFDR (:mod:`rast.model.radar.sfdr`) of per-pulse samples of shape (gates, pulses), per gate and the worst.

    Each gate excludes the largest maximum Doppler of the windmills received at
    its sample. Returns ``{}`` with less than one CPI of pulses, and
    ``sfdr_db: None`` with the reason in ``sfdr_error`` when the turbines'
    band leaves nothing to measure; an SFDR with no line at all outside the
    band (+inf) is reported as ``None`` too.
    """
    from rast.model.radar.receiver import RangeBin
    from rast.model.radar.sfdr import farm_sfdr
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


def _reach_m(windmill) -> np.ndarray:
    """The projected radii r·cos(rotor angle) of the parts whose lines the check
    follows (m): the point scatterers, or, on a wire-only blade, the wire's tip
    (``wire_view_angle`` added to the rotor angle). A wire's flash spreads over
    0 … its tip's Doppler (seed eq. 2.20), no line: beside point scatterers it
    is not followed (in ``farm_ranges_tower.toml`` it reaches 5 % beyond them,
    40 dB under their lines)."""
    reach = np.asarray(windmill.radius_m, dtype=float) * np.cos(np.deg2rad(windmill.rotor_angle_deg))
    if reach.size == 0 and windmill.wire is not None:
        reach = np.array([windmill.wire.radius_max_m *
                          np.cos(np.deg2rad(windmill.rotor_angle_deg + windmill.wire.view_angle_deg))])
    return reach


def _scatterer_dopplers(windmill, wavelength_m: float, t_s: np.ndarray) -> np.ndarray:
    """Instantaneous Doppler (Hz) of every blade's every followed part (:func:`_reach_m`)
    at t, shape (blades × parts, T): ``f = 2·ω·r·cos(rotor)·cos(β_b(t))/λ``, the
    derivative of φ = −4πΔR/λ."""
    from rast.model.physics.turbine import blade_angles
    omega = 2 * np.pi * windmill.rpm / 60.0
    beta = blade_angles(windmill, t_s)                                  # (blades, T)
    r = _reach_m(windmill)[:, None, None]                               # (parts, 1, 1)
    f = 2 * omega * r * np.cos(beta)[None] / wavelength_m
    return f.reshape(-1, len(t_s))


def physics_doppler_track(windmill, wavelength_m: float, t_s: np.ndarray) -> np.ndarray:
    """The instantaneous Doppler of largest magnitude over the windmill's blades and
    scatterers at t (signed). Its extreme is the windmill's maximum Doppler
    (seed 4.3.3: 1460 Hz and 1870 Hz), reached on either side of zero."""
    f = _scatterer_dopplers(windmill, wavelength_m, t_s)
    return f[np.argmax(np.abs(f), axis=0), np.arange(len(t_s))]


def _hann_sidelobe_db(bins: np.ndarray) -> np.ndarray:
    """The envelope of the Hann window's sidelobes (dB under the line) at ``bins``
    ≥ 2 bins from a line: |sinc(d)/(1 − d²)| ≤ 1/(π·d·(d² − 1)) (−32 dB at 2.5
    bins, falling 18 dB per octave)."""
    d = np.asarray(bins, dtype=float)
    return -20 * np.log10(np.pi * d * (d * d - 1))


def signature_edge_hz(power_db: np.ndarray, doppler_hz: np.ndarray, side_sign: float, *,
                      reference_db: float | None = None, line_db: float = 30.0, floor_db: float = 60.0,
                      margin_db: float = 6.0, edge_db: float = 6.0) -> float:
    """The Doppler (Hz, signed) of the outermost spectral line of one spectrogram
    frame (dB over ascending Doppler bins) on one side of zero, 0.0 if that side
    holds none.

    The side's bins start two bins from zero: the Hann window's main lobe of a
    static return (tower, hub; seed Fig. 4.6's zero-Doppler line) reaches that
    far, and it is no blade's Doppler. A *line* is a local maximum that stands
    ``margin_db`` above the sidelobes of every stronger line of the frame
    (:func:`_hann_sidelobe_db`; 6 dB for several lines' sidelobes adding up)
    and within ``line_db`` of the strongest such on its side: at its peak the
    tip's line lies within a few dB of its own blade's other scatterers, the
    replay's images 50 dB and more under them. ``floor_db`` under
    ``reference_db`` (the strongest bin of the whole spectrogram; default: of
    the frame) bounds the search where a side holds no signature at all.

    The outermost line's Doppler is read off its outer flank: the Hann
    window's main lobe is exactly ``edge_db`` = 6 dB down one bin from its
    centre, so the frequency
    where the power falls 6 dB under the line's peak bin (interpolated in dB
    between two bins), less one bin, is the line's centre (within 0.11 bin for
    a line alone). Unlike the peak it keeps following the outermost line when
    a neighbour less than a main lobe inside merges with it (the scatterers of
    one blade lie 1.2–1.5 bins apart in the examples): within half a bin for
    two to eight such lines.
    """
    res = float(doppler_hz[1] - doppler_hz[0])
    p = np.asarray(power_db, dtype=float)
    peaks = np.nonzero((p >= np.concatenate([[-np.inf], p[:-1]])) & (p > np.concatenate([p[1:], [-np.inf]]))
                       & (p >= (p.max() if reference_db is None else reference_db) - floor_db))[0]
    peaks = peaks[side_sign * doppler_hz[peaks] >= 1.999 * res]
    if peaks.size == 0:
        return 0.0
    every = np.nonzero((p >= np.concatenate([[-np.inf], p[:-1]])) & (p > np.concatenate([p[1:], [-np.inf]])))[0]
    distance = np.abs(peaks[:, None] - every[None, :]).astype(float)
    stronger = (p[every][None, :] > p[peaks][:, None]) & (distance >= 2)
    sidelobes = np.where(stronger, p[every][None, :] + _hann_sidelobe_db(np.maximum(distance, 2)), -np.inf)
    lines = peaks[p[peaks] >= sidelobes.max(axis=1, initial=-np.inf) + margin_db]
    if lines.size == 0:
        return 0.0
    lines = lines[p[lines] >= p[lines].max() - line_db]
    k = int(lines[np.argmax(side_sign * doppler_hz[lines])])
    step = 1 if side_sign > 0 else -1
    level = p[k] - edge_db
    m = k
    while 0 <= m + step < p.size and p[m + step] >= level:
        m += step
    if not 0 <= m + step < p.size:       # the flank leaves the band: the band's edge
        return float(doppler_hz[m])
    crossing = (p[m] - level) / (p[m] - p[m + step])          # bins beyond m
    return float(doppler_hz[m] + step * (crossing - 1) * res)


def _gate_edge_physics(farm, members: list[int], wavelength_m: float, side_sign: float, centre_s: float,
                       cpi_s: float, res: float, measured: float) -> tuple[float, str]:
    """The physics nearest to a measured edge in the frame centred at ``centre_s``:
    ``(Hz, name of the windmill whose span is nearest to it)``.

    Each member's Doppler on this side spans, during the frame, from its value
    at the centre to the farthest it reaches (one value for a windmill at its
    peak, where its Doppler stands still). The outermost line belongs to the
    member of the largest centre value F, or to one sweeping farther out during
    the frame (the largest farthest value bounds the edge from above). Members
    whose centre values lie within two bins inside F (the Hann window's main
    lobe reaches two bins) are not resolved from it: their lines merge with it
    into one lobe whose flank the strongest of them sets, so the edge may lie
    as far in as the innermost of them. ``members[0]`` is named first when
    its span holds the value.
    """
    during = np.linspace(centre_s - cpi_s / 2, centre_s + cpi_s / 2, 129)   # odd: the middle is the centre
    spans = []
    for mi in members:
        on_side = (side_sign * _scatterer_dopplers(farm.windmills[mi], wavelength_m, during)).max(axis=0)
        centre = max(float(on_side[during.size // 2]), 0.0)
        far = max(float(on_side.max()), centre)
        if far > res:                           # else no line of this member on this side
            spans.append((centre, far, farm.windmills[mi].name))
    if not spans:                               # a Doppler under one bin
        return 0.0, farm.windmills[members[0]].name
    top = max(c for c, _, _ in spans)
    low = min(c for c, _, _ in spans if c >= top - 2 * res)
    high = max(f for _, f, _ in spans)
    nearest = min(max(side_sign * measured, low), high)
    distance = [max(c - nearest, nearest - f, 0.0) for c, f, _ in spans]
    return side_sign * nearest, spans[int(np.argmin(distance))][2]


def doppler_aliased(e: E2E) -> bool:
    """Whether a turbine's maximum Doppler reaches ±PRF/2, where the radar's
    slow time aliases it (:func:`doppler_check` then has no edge to find)."""
    return max(s.plan.max_doppler_hz for s in e.streams.streams) >= e.farm.radar.prf_hz / 2


def doppler_check(e: E2E, spectra: list) -> list[dict]:
    """For each windmill: its maximum Doppler in the RTL spectrogram against the physics.

    Where: the frames about the instant its physical Doppler peaks, in which
    that Doppler stays within half a bin of the peak (one frame without
    overlap, tens with the testbench's 0.9). What: in each frame, the Doppler
    of the outermost spectral line on the peak's side of zero
    (:func:`signature_edge_hz`, searched over the whole half band, not in a
    window around the expected value, so that a misplaced or missing
    signature fails), against the physics of the gate at that frame
    (``physics_hz``). ``ok`` when the median frame is within one bin, that is
    when more than half of the frames are (``frames``, ``frames_within_bin``),
    and the peak falls inside the run (``reached``).

    Why the outermost line and not, as before, the farthest bin within 6 dB of
    the frame's strongest line: at the instant a blade's tip reaches the
    maximum Doppler the blade is perpendicular to the line of sight, and the
    rest of the turbine is elsewhere in the spectrum. The tip is one
    scatterer. A three-bladed rotor's two other blades then sit both at −½ of
    the peaking blade's Doppler, scatterer by scatterer on the same lines
    (twice the amplitude on half the spread); a tower or hub adds a static
    line at 0 Hz; the blade's flash (the wire of seed eq. 2.20) spreads its
    energy evenly over 0 … the tip's Doppler. So the tip's line lies up to
    14 dB under the frame's strongest line in the 64-turbine examples (a
    turbine alone in its gate), 23–27 dB under a 100 m² tower; the old rule
    often found no bin on the physics' side and reported 0 Hz, although the
    line was where the physics puts it. The outermost line is where the
    maximum Doppler shows, whatever else is stronger.

    Why several frames: lines less than a main lobe apart (two bins) are not
    resolved by the Hann window, and their sum in one frame depends on their
    phases, which turn at their Doppler difference from frame to frame; a
    single frame can show the outermost line cancelled or pushed out by more
    than a bin. The median frame is what the spectrogram shows steadily.

    Windmills that share a range gate share its spectrogram; there the edge
    is the gate's (:func:`_gate_edge_physics`): between the largest Doppler any
    member has at the frame's centre (or the innermost of those within two
    bins of it, which merge with it) and the farthest any member reaches
    during the frame (``explained_by``: the member whose span is nearest;
    ``windmill_hz``: this windmill's own value at the frame's centre). Alone in
    its gate a windmill sets its own edge, and at its peak its Doppler stands
    still, so the physics is one value. A shared gate is checked as loosely as
    its members are alike: a wrong rate or scale fails in every gate, a
    mirrored signature in every gate of one or two turbines, but eight
    similar rotors at random blade angles in one gate are nearly symmetric in
    Doppler, and a mirror can pass there (docs/farm_layouts.md)."""
    farm = e.farm
    lam = farm.radar.wavelength_m
    # the windmills whose echo is at each gate's sample (eq. 2.3); without a pulse
    # (a model radar's range bins) the gate's own list holds them already
    received = [gate_windmills(e, g) if e.pulse is not None else list(m) for g, (_, _, m) in enumerate(e.gates)]
    out = []
    for g, (_, rk, members) in enumerate(e.gates):
        spec = spectra[g]
        res = spec.resolution_hz
        cpi_s = 1.0 / res
        strongest = float(spec.power_db.max())
        for wi in members:
            w = farm.windmills[wi]
            track = physics_doppler_track(w, lam, spec.times_s)
            j = int(np.argmax(np.abs(track)))
            own = float(track[j])
            side_sign = 1.0 if own >= 0 else -1.0
            # The frames about the peak in which this windmill's Doppler stays within
            # half a bin of it: each gives an edge and the physics of its own instant.
            near = side_sign * track >= abs(own) - res / 2
            first, last = j, j
            while first > 0 and near[first - 1]:
                first -= 1
            while last < near.size - 1 and near[last + 1]:
                last += 1
            frames = []
            for k in range(first, last + 1):
                edge = signature_edge_hz(spec.power_db[k], spec.doppler_hz, side_sign, reference_db=strongest)
                physics, holder = _gate_edge_physics(farm, [wi] + [m for m in received[g] if m != wi], lam,
                                                     side_sign, spec.times_s[k], cpi_s, res, edge)
                frames.append((abs(edge - physics), k, edge, physics, holder))
            # the median frame: the check passes when more than half of them are within a bin
            frames.sort()
            _, k, measured, physics, holder = frames[len(frames) // 2]
            within = sum(err <= res for err, *_ in frames)
            fine = np.linspace(spec.times_s[0], spec.times_s[-1], 20001)
            run_max = float(np.abs(physics_doppler_track(w, lam, fine)).max())
            # the largest Doppler of the followed parts (max_doppler_hz, but for a wire
            # beside points); it is only seen if its peak falls inside the frames
            top = float(2 * (2 * np.pi * w.rpm / 60.0) * np.abs(_reach_m(w)).max(initial=0.0) / lam)
            reached = run_max >= top - res
            out.append(dict(windmill=w.name, range_km=rk, frame_time_s=float(spec.times_s[k]),
                            physics_hz=physics, explained_by=holder, windmill_hz=float(track[k]),
                            measured_hz=measured, bin_hz=res, frames=len(frames), frames_within_bin=within,
                            physics_run_max_hz=run_max, physics_max_hz=top, reached=bool(reached),
                            ok=bool(reached and abs(measured - physics) <= res)))
    return out


def save_json(path, obj):
    Path(path).write_text(json.dumps(obj, indent=2, default=float))
