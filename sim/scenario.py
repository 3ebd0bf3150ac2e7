"""Scenarios for the wind-farm top: stimulus, register script, and the model's answer.

A :class:`Scenario` is everything one bulk run needs: the elaboration
parameters (:class:`~rast.model.contract.fixedpoint.ReplayContract`), the
:class:`~rast.sim.bulk.BulkJob` (input words, idle pattern, register script,
valid gaps, capture plan) and a name. :func:`model_outputs` replays the same
input sequence and register script through the bit-exact model
(:class:`~rast.model.contract.datapath.ReplayModel`): a write scripted "at sample n"
is issued after sample n-1 and before sample n, which is exactly what the
wrapper does in the RTL (it never writes in a cycle that transfers a sample).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rast.model.contract import fixedpoint as fx
from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import ReplayContract
from rast.model.radar.pulses import PulseConfig, generate
from rast.model.contract.regmap import CTRL_ENABLE, CTRL_SWAP, register_map
from rast.model.contract.loadplan import manifest_to_register_writes, pool_layout, free_region, stream_writes

from .bulk import BulkJob

__all__ = ["TEST_CONTRACT", "Scenario", "job_inputs", "model_outputs", "ModelBeside", "random_scenario",
           "farm_scenario", "worst_fetch_scenario"]


@dataclass
class Scenario:
    name: str
    contract: ReplayContract
    job: BulkJob
    sample_rate_hz: float = 20e6
    #: the block's power-up state (ChannelInit per channel; None: as reset) and COMMON_DELAY
    inits: list | None = None
    common_delay: int = 0


def job_inputs(job: BulkJob) -> tuple[np.ndarray, np.ndarray]:
    """The full input sequence (I, Q) the wrapper feeds for ``job``."""
    n_body = job.pulses * job.pri
    words = np.zeros(job.n_in, dtype=np.int64)
    if job.active:
        take = np.arange(job.pulses * job.active) % len(job.src)
        body = np.zeros((job.pulses, job.pri), dtype=np.int64)
        body[:, :job.active] = np.asarray(job.src, dtype=np.int64)[take].reshape(job.pulses, job.active)
        words[:n_body] = body.reshape(-1)
    return fx.unpack_iq(words, fx.INPUT_WIDTH)


def model_outputs(sc: Scenario, xi=None, xq=None):
    """``(yi, yq, overflow)`` of the bit-exact model for the scenario."""
    if xi is None:
        xi, xq = job_inputs(sc.job)
    m = ReplayModel(sc.contract, sc.inits, sc.common_delay)
    yi, yq = m.run_with_writes(xi, xq, sc.job.regs)
    return yi, yq, int(m.overflow)


class ModelBeside:
    """:func:`model_outputs` in a forked process, started before the simulation so that
    the model runs on the second core while the simulator runs on the first.

    The child writes ``model.npz`` into ``directory``; :meth:`result` waits for it and
    returns what :func:`model_outputs` returns. A child that fails is reported with its
    exit code (the model is then run here, so a run never loses its check).
    """

    def __init__(self, sc: Scenario, directory):
        import multiprocessing
        from pathlib import Path
        self._sc = sc
        self._path = Path(directory) / "model.npz"
        self._path.unlink(missing_ok=True)
        self._proc = multiprocessing.get_context("fork").Process(
            target=_model_to_file, args=(sc, self._path), daemon=True)
        self._proc.start()

    def result(self):
        self._proc.join()
        if self._proc.exitcode != 0 or not self._path.exists():
            import warnings
            warnings.warn(f"the model process ended with {self._proc.exitcode}; running the model here")
            return model_outputs(self._sc)
        with np.load(self._path) as f:
            out = f["yi"], f["yq"], int(f["overflow"])
        self._path.unlink()
        return out


def _model_to_file(sc: Scenario, path) -> None:
    yi, yq, overflow = model_outputs(sc)
    tmp = path.with_name(path.stem + ".partial.npz")
    np.savez(tmp, yi=yi, yq=yq, overflow=overflow)
    tmp.rename(path)


# ---------------------------------------------------------------------------
# Random register sequences

class PoolTracker:
    """The pool regions each channel may be playing, as a host without a
    read-back must assume them: a load switched at the period boundary may
    still find the old stream playing (even an older one, when loads follow
    each other within a period); a forced switch leaves only the stream the
    registers name. New streams go where none of them lies."""

    def __init__(self, contract, regions=()):
        self.c = contract
        self.playing = [[] for _ in range(contract.channels)]    # (base, length) per channel
        self.named = [None] * contract.channels                   # what BASE/LENGTH say
        for ch, region in enumerate(regions):
            self.playing[ch] = [region]
            self.named[ch] = region

    def place(self, ch, length, *, force=False):
        """Pool address for a new stream of channel ``ch`` (``None``: no room);
        the region is as long as the channel will read (LENGTH's clamp)."""
        length = max(length, self.c.min_stream_length)
        in_use = [r for regs in self.playing for r in regs]
        try:
            base = free_region(in_use, length, self.c.pool_words)
        except ValueError:
            return None
        self.named[ch] = (base, length)
        self.playing[ch] = [(base, length)] if force else self.playing[ch] + [(base, length)]
        return base

    def refused(self, ch, named_before):
        """The switch to the stream just placed for ``ch`` is refused (its CRC):
        its region is free again and the channel goes on as before."""
        self.playing[ch].remove(self.named[ch])
        self.named[ch] = named_before

    def forced_switch(self, ch):
        self.playing[ch] = [self.named[ch]] if self.named[ch] else []


def _stream_load(rmap, ch, words, length, inc, base, enable=True, force=False, corrupt=None):
    """Write a stream into the pool at ``base`` and switch channel ``ch`` to it:
    at the active stream's next period boundary, or at once (``force``:
    disable, switch, re-enable, as a host does at start-up). A stream shorter
    than the shortest LENGTH is written padded with zeros to it (the block
    takes a switch only for LENGTH words written). ``corrupt`` (a word index)
    flips one bit of that word on its way, after the CRC-32 was computed: the
    block must refuse the switch and keep playing the old stream."""
    a = rmap.addr
    n = max(length, rmap.contract.min_stream_length)
    words = list(words[:length]) + [0] * (n - min(length, len(words)))
    w = [(a("CTRL", ch), 0)] if force else []
    load = stream_writes(rmap, ch, base, words, inc)
    if corrupt is not None:
        addr, value = load[1 + corrupt]
        load[1 + corrupt] = (addr, value ^ 1 << 7)
    w += load
    if force:
        w += [(a("CTRL", ch), CTRL_SWAP), (a("CTRL", ch), CTRL_ENABLE if enable else 0)]
    else:
        w += [(a("CTRL", ch), (CTRL_ENABLE if enable else 0) | CTRL_SWAP)]
    return w


def _random_words(rng, n, full_scale=False):
    if full_scale:
        i = rng.choice([fx.STREAM.min, fx.STREAM.max], size=n)
        q = rng.choice([fx.STREAM.min, fx.STREAM.max], size=n)
    else:
        i = rng.integers(fx.STREAM.min, fx.STREAM.max + 1, size=n)
        q = rng.integers(fx.STREAM.min, fx.STREAM.max + 1, size=n)
    return fx.pack_iq(i, q)


#: Gains with many trailing zero bits: p * g then lands exactly on rounding ties
#: (low 16 bits 0x8000) for odd p, so the gain stage's round-half-up is exercised.
_UNITY = 1 << fx.GAIN_FRAC
TIE_GAINS = (_UNITY // 2, 3 * _UNITY // 4, _UNITY + _UNITY // 2, 5 * _UNITY // 8, _UNITY)


def _random_gain(rng):
    if rng.random() < 0.4:
        return int(rng.choice(TIE_GAINS))
    return int(rng.integers(0, fx.GAIN.max + 1))


_ONE_WORD = 1 << fx.PHASE_FRAC_BITS


def _random_inc(rng):
    kind = rng.integers(0, 4)
    if kind == 0:
        return int(rng.integers(1, 1 << 20))                  # very slow
    if kind == 1:
        return _ONE_WORD - 1                                  # one word per sample (seed mode)
    return int(rng.integers(1 << 24, _ONE_WORD))


#: One contract for every random top test, so a channel count is one build.
TEST_CONTRACT = dict(pool_words=4096, max_delay=200, max_tap=40)


def random_scenario(channels: int, seed: int, *, kind: str = "random", pulses: int = 40,
                    interpolation: str = "fir",
                    pri: int = 240, pulse_samples: int = 48, gap_thresh: int = 48,
                    stall_thresh: int = 48, mid_run_writes: int = 8, contract: dict | None = None) -> Scenario:
    """Random streams, delays, gains and enables, and random register writes at
    random samples mid-run (gains, enables, delays with APPLY, stream reloads
    with a bank switch at the period boundary, a quarter of them with a bit
    flipped on the way so that the block refuses them by their CRC-32, forced
    switches, taken only when the channel's stream was the last one written).

    ``kind="saturate"``: full-scale input, full-scale stream words and gains
    near the maximum, so that the channel sum saturates (and the sticky
    overflow flag is set).
    """
    rng = np.random.default_rng(seed)
    c = ReplayContract(channels=channels, interpolation=interpolation, **(contract or TEST_CONTRACT))
    rmap = register_map(c)
    a = rmap.addr
    full = kind == "saturate"
    regs = []
    pool = PoolTracker(c)
    for ch in range(channels):
        length = int(rng.integers(1, 160))
        gain = int(rng.integers(fx.GAIN.max + 1 - 4096, fx.GAIN.max + 1)) if full else _random_gain(rng)
        base = pool.place(ch, length, force=True)
        if base is None:
            raise ValueError(f"The streams of {channels} channels do not fit a {c.pool_words}-word pool "
                             f"(channel {ch}, {length} words): give the scenario a larger pool_words")
        regs += [(0, *w) for w in _stream_load(rmap, ch, _random_words(rng, length, full), length,
                                               _random_inc(rng), base,
                                               enable=full or rng.random() < 0.85, force=True)]
        regs += [(0, a("GAIN", ch), gain),
                 (0, a("DELAY", ch), int(rng.integers(0, c.max_tap + 1)))]
    regs += [(0, a("COMMON_DELAY"), int(rng.integers(0, c.max_delay + 1))), (0, a("APPLY"), 1)]
    n_body = pulses * pri
    at_points = np.sort(rng.integers(1, n_body, size=mid_run_writes))
    for at in at_points:
        at = int(at)
        ch = int(rng.integers(0, channels))
        what = rng.integers(0, 6)
        if what == 0:
            regs.append((at, a("GAIN", ch), _random_gain(rng)))
        elif what == 1:
            regs.append((at, a("CTRL", ch), int(rng.integers(0, 2))))          # enable toggle
        elif what == 2:
            for k in range(channels):
                regs.append((at, a("DELAY", k), int(rng.integers(0, c.max_tap + 1))))
            if rng.random() < 0.5:
                regs.append((at, a("COMMON_DELAY"), int(rng.integers(0, c.max_delay + 1))))
            regs.append((at, a("APPLY"), 1))
        elif what == 3 or what == 4:                                            # stream reload
            length = int(rng.integers(1, 1024)) if rng.random() < 0.3 else int(rng.integers(1, 64))
            named = pool.named[ch]
            base = pool.place(ch, length)
            if base is not None:
                # one reload in four loses a bit on the way: refused, the old stream plays on
                bad = int(rng.integers(0, length)) if rng.random() < 0.25 else None
                regs += [(at, *w) for w in _stream_load(rmap, ch, _random_words(rng, length, full),
                                                       length, _random_inc(rng), base, corrupt=bad)]
                if bad is not None:
                    pool.refused(ch, named)
        else:                                                                   # forced switch
            regs += [(at, a("CTRL", ch), 0), (at, a("CTRL", ch), CTRL_SWAP),
                     (at, a("CTRL", ch), CTRL_ENABLE)]
            pool.forced_switch(ch)
    amp = 1.0 if full else float(rng.uniform(0.2, 0.9))
    cfg = PulseConfig(sample_rate_mhz=20, prf_hz=20e6 / pri, pulse_width_us=pulse_samples / 20,
                      shape="chirp", bandwidth_mhz=float(rng.uniform(1, 20)), amplitude=amp,
                      carrier_offset_hz=float(rng.uniform(-2e6, 2e6)),
                      noise_rms=0.3 if full else 0.01, seed=seed, n_pulses=pulses)
    train = generate(cfg)
    job = BulkJob(src=train.words(), active=pri, pri=pri, pulses=pulses,
                  flush=c.latency + c.max_delay + c.max_tap + 8,
                  regs=regs, gap_thresh=gap_thresh, gap_max=5, stall_thresh=stall_thresh,
                  seed=seed + 1)
    return Scenario(f"{kind}-{channels}ch-m{c.slots}-seed{seed}", c, job, 20e6)


def farm_scenario(channels: int, seed: int, *, pulses: int = 30, gap_thresh: int = 32,
                  stall_thresh: int = 32, contract: dict | None = None) -> Scenario:
    """A random farm built by the golden model (streams, delays, gains from
    ``rast.model.physics.stream``), loaded with ``manifest_to_register_writes``,
    then reloaded mid-run with a second random farm's streams."""
    from rast.model.physics.farm import parse_config
    from rast.model.physics.stream import build_farm_streams
    rng = np.random.default_rng(seed)
    c = ReplayContract(channels=channels, **(contract or TEST_CONTRACT))
    fs_mhz = 10.0
    sample_m = 299_792_458.0 / (2 * fs_mhz * 1e6)          # range per delay sample

    def farm(n_wm):
        base = (c.latency + int(rng.integers(0, 80))) * sample_m / 1e3
        ranges, r = [], base
        for _ in range(n_wm):      # the farm's depth within the delay window
            ranges.append(round(r, 6))
            r += int(rng.integers(0, c.max_tap // max(1, n_wm - 1) + 1)) * sample_m / 1e3
        mills = []
        for k, rk in enumerate(ranges):
            nb = int(rng.integers(1, 4))
            nr = int(rng.integers(1, 4))
            mills.append({"name": f"w{k}", "range": rk, "num_blades": nb,
                          "rpm": float(rng.uniform(10, 40)), "num_rcs": nr,
                          "radius": sorted(rng.uniform(1, 6, size=nr).round(3).tolist()),
                          "rsc": rng.uniform(0.2, 2, size=nr).round(3).tolist(),
                          "start_angle": float(rng.uniform(0, 360))})
        return parse_config({"sample_rate": fs_mhz, "radar_frequency": 300.0, "prf": 10_000,
                             "pulse_width": 4, "cpi": 100, "ram_depth": c.pool_words,
                             "windmill": mills})
    f1 = farm(int(rng.integers(1, channels + 1)))
    s1 = build_farm_streams(f1)
    w1 = manifest_to_register_writes(s1.manifest(), c, streams=[s.words for s in s1.streams])
    regs = [(0, addr, val) for addr, val in w1]
    # mid-run: reload every channel of farm 1 with a second farm's streams (switch at the
    # period boundary, no disable), and change the gains
    f2 = farm(len(s1.streams))
    s2 = build_farm_streams(f2)
    rmap = register_map(c)
    lengths = [s.plan.length for s in s1.streams]
    pool = PoolTracker(c, list(zip(pool_layout(lengths, c.pool_words), lengths)))
    pri = 1000
    at = int(rng.integers(pri, pulses * pri // 2))
    for ch, s in enumerate(s2.streams):
        base = pool.place(ch, s.plan.length)
        if base is None:
            raise ValueError(f"farm scenario: no room in the pool for the reload of channel {ch}")
        regs += [(at, *w) for w in _stream_load(rmap, ch, s.words, s.plan.length,
                                               s.plan.phase_increment, base)]
        regs.append((at, rmap.addr("GAIN", ch), s.gain_word))
    cfg = PulseConfig(sample_rate_mhz=fs_mhz, prf_hz=fs_mhz * 1e6 / pri, pulse_width_us=4, shape="rect",
                      amplitude=0.7, carrier_offset_hz=float(rng.uniform(-1e5, 1e5)),
                      noise_rms=0.005, seed=seed, n_pulses=pulses, noise_in_pulse_only=True)
    active = cfg.pulse_samples
    train = generate(cfg, active_samples=active)
    job = BulkJob(src=train.words(), active=active, pri=pri, pulses=pulses,
                  flush=c.latency + c.max_delay + c.max_tap + 8, regs=regs,
                  gap_thresh=gap_thresh, gap_max=3, stall_thresh=stall_thresh, seed=seed + 7)
    return Scenario(f"farm-{channels}ch-m{c.slots}-seed{seed}", c, job, fs_mhz * 1e6)


#: Samples between two host writes of the worst-case scenario's stream load.
HOST_WRITE_SAMPLES = 4


def worst_fetch_scenario(channels: int, seed: int, *, interpolation: str = "linear", pulses: int = 80,
                         gap_thresh: int = 0, stall_thresh: int = 0, contract: dict | None = None) -> Scenario:
    """The fetch schedule the contract's bounds are derived for (docs/sdram.md):
    every channel at the highest stream rate (PHASE_INC = max_phase_increment)
    from start to end; all channels switched at once at the start and again
    at mid-run, so that every cache refills together; between the two, the
    host writes a stream of a quarter of the pool (channel 0's reload,
    switched at its period boundary), a word every HOST_WRITE_SAMPLES
    samples (faster than the SDRAM takes them), while all channels play.
    No valid gaps by default: a sample every period is the fastest consumption."""
    rng = np.random.default_rng(seed)
    c = ReplayContract(channels=channels, interpolation=interpolation, **(contract or TEST_CONTRACT))
    rmap = register_map(c)
    a = rmap.addr
    inc = c.max_phase_increment
    pool = PoolTracker(c)
    n_body = pulses * 240

    def load_all(at, longest):
        out = []
        for ch in range(channels):
            length = int(rng.integers(c.min_stream_length, longest + 1))
            base = pool.place(ch, length, force=True)
            if base is None:
                raise ValueError(f"worst-case scenario: no room in a {c.pool_words}-word pool for channel {ch}")
            out += [(at, *w) for w in _stream_load(rmap, ch, _random_words(rng, length), length, inc, base,
                                                   force=True)]
        return out

    regs = load_all(0, 24)
    regs += [(0, a("GAIN", ch), int(rng.integers(fx.GAIN.max // 8, fx.GAIN.max // 4))) for ch in range(channels)]
    regs += [(0, a("DELAY", ch), int(rng.integers(0, c.max_tap + 1))) for ch in range(channels)]
    regs += [(0, a("COMMON_DELAY"), int(rng.integers(0, c.max_delay + 1))), (0, a("APPLY"), 1)]
    # the host's stream: one write every HOST_WRITE_SAMPLES samples (the
    # wrapper holds the input back while a write waits, so writes in one
    # sample would stop consumption), faster than the SDRAM takes them
    big = c.pool_words // 4
    base = pool.place(0, big)
    load = _stream_load(rmap, 0, _random_words(rng, big), big, inc, base)
    start = n_body // 4
    if start + HOST_WRITE_SAMPLES * len(load) >= n_body // 2:
        raise ValueError(f"worst-case scenario: {pulses} pulses leave no room for the host's "
                         f"{len(load)} writes; give it more pulses")
    regs += [(start + HOST_WRITE_SAMPLES * k, *w) for k, w in enumerate(load)]
    regs += load_all(n_body // 2, 96)
    cfg = PulseConfig(sample_rate_mhz=20, prf_hz=20e6 / 240, pulse_width_us=240 / 20, shape="chirp",
                      bandwidth_mhz=5.0, amplitude=0.5, noise_rms=0.01, seed=seed, n_pulses=pulses)
    train = generate(cfg)
    job = BulkJob(src=train.words(), active=240, pri=240, pulses=pulses,
                  flush=c.latency + c.max_delay + c.max_tap + 8, regs=regs, gap_thresh=gap_thresh,
                  gap_max=3, stall_thresh=stall_thresh, seed=seed + 3)
    return Scenario(f"worst-{channels}ch-m{c.slots}-{interpolation}-seed{seed}", c, job, 20e6)
