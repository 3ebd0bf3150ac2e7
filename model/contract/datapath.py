"""Bit-exact model of the replay block (``rast.hdl.replay_top.WindFarmReplay``).

Integer numpy (int64) throughout. Time is counted in *steps*: step ``n`` is the
``n``-th accepted input sample, and output sample ``n`` is the one the block
emits for it (one out per one in, whatever the gaps in ``valid``). A register
write issued after step ``n-1`` was accepted and before step ``n`` is accepted
takes effect at step ``n`` (in the gateware: a write taken from the bus in the
same clock cycle as an input transfer counts as after that transfer); a read
there returns the state after step ``n-1``.

Equations (N channels, l = 0..N-1, every value as applied at step n; the
fixed-point contract ``rast.model.contract.fixedpoint``, "The time-multiplexed engine"):

* common delay line and window: ``c[n] = x[n - COMMON_LAG - d_c[n]]``,
  ``t_l[n] = c[n - WINDOW_LAG - d_l[n]]`` (``d_c`` the applied COMMON_DELAY,
  ``d_l`` the applied DELAY, the tap, of channel l),
* stream word ``w_l[n] = word(state_l[n])``, the phase held during step n,
* ``p_l[n] = cmult(t_l[n], w_l[n])``, ``q_l[n] = gain(p_l[n], g_l[n])``
  (``g_l`` = GAIN if enabled else 0; with the antenna scan playing,
  ``scanned_gain(GAIN, pattern(beam[n] - AZIMUTH_l))``, ``rast.model.contract.scan``),
* ``y[n] = saturate(sum_l q_l[n])``.

Hence an echo of channel l appears ``L + d_c + d_l`` samples after the input,
``L = COMMON_LAG + WINDOW_LAG``. Everything before step 0 is zero.
"""

import numpy as np

from rast.model.contract.fixedpoint import (ReplayContract, GAIN, PRODUCT_SHIFT, GAIN_SHIFT, OUTPUT_WIDTH,
                                            INTERP_FRAC_BITS, PHASE_FRAC_BITS, COMMON_LAG, WINDOW_LAG,
                                            STREAM_WIDTH, FIR_PHASE_BITS, FIR_PHASES, FIR_TAPS, FIR_LEAD,
                                            FIR_COEF_FRAC, fir_coefficients, round_half_up, saturate,
                                            pack_iq, unpack_iq)
from rast.model.contract.regmap import register_map, stream_crc32, APPLIED_LSB
from rast.model.contract.powerup import ChannelInit, pool_contents
from rast.model.contract.scan import (BeamGenerator, PatternWords, PATTERN_ENTRIES, PATTERN_WIDTH, pattern_lookup,
                                      scanned_gain)

__all__ = ["cmult", "gain_scale", "interpolate_words", "fir_table", "stream_words",
           "phase_sequence", "delay_line", "channel_sum", "ReplayModel"]

ONE = 1 << PHASE_FRAC_BITS


def cmult(ai, aq, bi, bq, shift=PRODUCT_SHIFT):
    """Full-precision complex product rounded half up by ``shift`` bits (either form)."""
    ai, aq, bi, bq = (np.asarray(v, dtype=np.int64) for v in (ai, aq, bi, bq))
    re = ai * bi - aq * bq
    im = ai * bq + aq * bi
    return round_half_up(re, shift), round_half_up(im, shift)


def gain_scale(p, g, shift=GAIN_SHIFT):
    """``round_half_up(p * g, shift)``; ``g`` unsigned gain word."""
    return round_half_up(np.asarray(p, dtype=np.int64) * np.asarray(g, dtype=np.int64), shift)


def interpolate_words(s0, s1, frac32):
    """Linear interpolation of signed components: ``s0 + rhu((s1-s0)*f, 16)``,
    ``f`` the top ``INTERP_FRAC_BITS`` of the 32-bit phase fraction."""
    f = np.asarray(frac32, dtype=np.int64) >> (PHASE_FRAC_BITS - INTERP_FRAC_BITS)
    s0 = np.asarray(s0, dtype=np.int64)
    return s0 + round_half_up((np.asarray(s1, dtype=np.int64) - s0) * f, INTERP_FRAC_BITS)


def fir_table(i, q):
    """The FIR stage's intermediate sequence of one period of words (signed
    I and Q, length L): ``U[J]`` for J in [0, FIR_PHASES*L), shape (2, 16L).
    ``U[J] = sat16(rhu(sum_k c[p][k]*m[(w + FIR_LEAD - k) mod L], FIR_COEF_FRAC))``
    with ``w = J >> FIR_PHASE_BITS``, ``p = J mod FIR_PHASES``."""
    m = np.stack([np.asarray(i, dtype=np.int64), np.asarray(q, dtype=np.int64)])
    L = m.shape[1]
    c = np.array(fir_coefficients(), dtype=np.int64)                    # (phases, taps)
    taps = (np.arange(L)[:, None] + FIR_LEAD - np.arange(FIR_TAPS)[None, :]) % L   # (L, taps)
    acc = m[:, taps] @ c.T                                              # (2, L, phases)
    u, _ = saturate(round_half_up(acc, FIR_COEF_FRAC), STREAM_WIDTH)
    return u.reshape(2, L * FIR_PHASES)


def stream_words(interpolation, words, length, phases, table=None):
    """The stream word (I, Q) at the multiplier for each phase (units of
    2**-32 words, below ``length * 2**32``) under the contract's
    ``interpolation``. ``table`` may pass a precomputed :func:`fir_table`."""
    phases = np.asarray(phases, dtype=np.int64)
    words = np.asarray(words, dtype=np.int64)[:length]
    wi, wq = unpack_iq(words)
    idx = phases >> PHASE_FRAC_BITS
    if interpolation == "hold":
        return wi[idx], wq[idx]
    frac = phases & (ONE - 1)
    if interpolation == "linear":
        idx1 = np.where(idx + 1 >= length, 0, idx + 1)
        return interpolate_words(wi[idx], wi[idx1], frac), interpolate_words(wq[idx], wq[idx1], frac)
    u = fir_table(wi, wq) if table is None else table
    j = phases >> (PHASE_FRAC_BITS - FIR_PHASE_BITS)
    j1 = np.where(j + 1 >= length * FIR_PHASES, 0, j + 1)
    f = (frac << FIR_PHASE_BITS) & (ONE - 1)
    return interpolate_words(u[0, j], u[0, j1], f), interpolate_words(u[1, j], u[1, j1], f)


def phase_sequence(start, inc, length, n):
    """Phases (units of 2**-32 words) visible during ``n`` steps from ``start``,
    free running: ``(start + k*inc) mod (length * 2**32)``."""
    k = np.arange(n, dtype=np.int64)
    return (int(start) + k * int(inc)) % (int(length) * ONE)


def delay_line(x, d, lag):
    """A delay line read at a tap that may change: ``out[n] = x[n - lag - d[n]]``,
    zeros before 0. ``d`` is the per-step applied delay (as long as ``x``)."""
    x = np.asarray(x, dtype=np.int64)
    d = np.asarray(d, dtype=np.int64)
    src = np.arange(len(x)) - lag - d
    out = np.zeros_like(x)
    good = src >= 0
    out[good] = x[src[good]]
    return out


def channel_sum(q, width=OUTPUT_WIDTH):
    """Sum of per-channel scaled products ``q`` (shape N x T, already aligned),
    saturated; returns (y, overflow per step)."""
    return saturate(np.sum(np.asarray(q, dtype=np.int64), axis=0), width)


class ReplayModel:
    """Step-by-step bit-exact model of :class:`WindFarmReplay`.

    Use :meth:`write`/:meth:`read` for register accesses (in the order the
    host issues them relative to samples) and :meth:`run` to push input
    samples; :meth:`run` returns the output samples for them.
    """

    def __init__(self, contract: ReplayContract, inits=None, common_delay: int = 0):
        self.c = c = contract
        inits = list(inits or []) + [ChannelInit()] * (c.channels - len(inits or []))
        self.rmap = register_map(c, inits, common_delay)
        N = c.channels
        self.pool = np.array(pool_contents(inits, c.pool_words), dtype=np.int64)
        self._amask = (1 << c.pool_address_width) - 1
        self.enable = [int(i.enable) for i in inits]
        self.base_next = [self.rmap.reg("BASE", l).field("base").reset for l in range(N)]
        self.base_act = list(self.base_next)
        self.len_next = [min(max(i.length, c.min_stream_length), c.pool_words) for i in inits]
        self.inc_next = [min(i.phase_increment & (ONE - 1), c.max_phase_increment) for i in inits]
        self.len_act = list(self.len_next)
        self.inc_act = list(self.inc_next)
        self.gain = [i.gain & GAIN.max for i in inits]
        self.delay_next = [min(i.delay, c.max_tap) for i in inits]
        self.delay_act = list(self.delay_next)
        self.common_next = self.rmap.reg("COMMON_DELAY").field("delay").reset
        self.common_act = self.common_next
        self.bank = [0] * N
        self.pending = [0] * N
        self.phase = [0] * N
        self.start_next = [0] * N                  # START (a block built with start_frac)
        self.scheduled = None                      # FOLLOW_SWITCH not yet taken: (channel, step)
        self.refill = [c.refill_samples] * N      # muted steps left, phase held
        self._tables = [None] * N                  # FIR table of the active stream, made on demand
        self._streams = [self.stream_of(l) for l in range(N)]   # the active streams' words
        self.stream_addr = 0
        # The stream write path's run, which a SWAP is checked against: start
        # address, words and CRC-32 since the last STREAM_ADDR write.
        self.run_start, self.run_count, self.run_crc = 0, 0, 0
        self._count_max = (1 << c.length_width) - 1
        self.crc_next = [0] * N
        # PLAYED: the CRC-32 of the stream of the last SWAP taken
        self.crc_played = [self.rmap.reg("PLAYED", l).field("crc").reset for l in range(N)]
        # whether BASE, LENGTH and CRC were each written since power-up: a
        # SWAP is checked against values the host stated (docs/registers.md)
        self._stated = [set() for _ in range(N)]
        self.check_crc = 0                 # POOL_CHECK_CRC (SDRAM pool)
        # the antenna scan (a block built with it): the settings as stored,
        # the beam's generator, the pattern table and its write path
        if c.scan:
            self.azimuth = [self.rmap.reg("AZIMUTH", l).field("azimuth").reset for l in range(N)]
            self.scan_regs = {name: self.rmap.reg(name).fields[0].reset
                              for name in ("SCAN_PERIOD", "SCAN_START", "PATTERN_ADDR")}
            if c.follow_rows:
                self.scan_regs.update({name: 0 for name in ("FOLLOW_WINDOW", "FOLLOW_SPAN", "TABLE_ADDR")})
                self.scan_regs["FOLLOW_CTRL"] = c.follow_rows << self.rmap.reg("FOLLOW_CTRL").field("capacity").lsb
            ctrl = self.rmap.reg("SCAN_CTRL")
            self.scan_ctrl = self._stored(ctrl, sum(f.reset << f.lsb for f in ctrl.fields))
            self.pattern_reg = 0
            self.table_crc = 0
            self.beam = BeamGenerator()
            self._configure_beam()
            self.table = np.zeros(PATTERN_ENTRIES, dtype=np.int64)
            self.pattern_crc = 0
        self.rejected = [0] * N
        self.overflow = 0
        self.steps = 0
        # Per-step histories (lists of arrays, concatenated on demand), kept
        # from absolute step self._base on: only the last `_lookback` steps
        # can influence new outputs, so run() costs O(new steps + lookback).
        self._x = [np.zeros((2, 0), dtype=np.int64)]
        self._d = [np.zeros((N + 1, 0), dtype=np.int64)]    # taps, then the common delay
        self._g = [np.zeros((N, 0), dtype=np.int64)]
        self._w = [np.zeros((N, 2, 0), dtype=np.int64)]
        self._base = 0
        self._lookback = c.latency + 16 + c.max_delay + c.max_tap

    # ---- registers -------------------------------------------------------
    def _swap(self, l):
        self.bank[l] ^= 1
        self.base_act[l] = self.base_next[l]
        self.len_act[l] = self.len_next[l]
        self.inc_act[l] = self.inc_next[l]
        self.phase[l] = self.start_next[l]        # START's fraction of word 0 (0 without start_frac)
        self.pending[l] = 0
        self.refill[l] = self.c.refill_samples
        self._tables[l] = None
        self._streams[l] = self.stream_of(l)     # the words the cache will be filled with

    def _stored(self, r, value):
        """``value`` written to register ``r`` as its stored fields keep it:
        each field masked and clamped, write strobes dropped."""
        out = 0
        for f in r.fields:
            if f.access in ("rw", "w"):
                v = (value >> f.lsb) & ((1 << f.width) - 1)
                if f.clamp:
                    v = min(max(v, f.clamp[0]), f.clamp[1])
                out |= v << f.lsb
        return out

    def _configure_beam(self):
        ctrl = self.rmap.reg("SCAN_CTRL")
        fv = {f.name: (self.scan_ctrl >> f.lsb) & ((1 << f.width) - 1) for f in ctrl.fields}
        self.beam.configure(fv["mode"], fv["anticlockwise"], fv["auto"], fv["acp_log2"],
                            self.scan_regs["SCAN_PERIOD"], self.scan_regs["SCAN_START"])

    def _write_scan(self, r, value):
        """A write to one of the antenna scan's registers."""
        if r.name == "AZIMUTH":
            self.azimuth[r.channel] = self._stored(r, value)
        elif r.name == "SCAN_CTRL":
            self.scan_ctrl = self._stored(r, value)
            self._configure_beam()
            if value & (1 << r.field("restart").lsb):
                self.beam.restart()
        elif r.name in ("SCAN_PERIOD", "SCAN_START"):
            self.scan_regs[r.name] = self._stored(r, value)
            self._configure_beam()
        elif r.name == "PATTERN":
            self.pattern_reg = self._stored(r, value)
        elif r.name == "PATTERN_ADDR":
            self.scan_regs[r.name] = self._stored(r, value)
            self.pattern_crc = 0
        elif r.name in ("FOLLOW_CTRL", "FOLLOW_WINDOW", "FOLLOW_SPAN"):
            # what the host reads back; the board's hand-out of channels is the
            # gateware's, checked against the model with one channel per turbine
            # (docs/beam_following.md), not modelled here
            ro = sum(f.reset << f.lsb for f in r.fields if f.access == "ro")     # (FOLLOW_CTRL.capacity)
            self.scan_regs[r.name] = self._stored(r, value) | ro
        elif r.name == "TABLE_ADDR":
            self.scan_regs[r.name] = self._stored(r, value)
            self.table_crc = 0
        elif r.name == "TABLE_DATA":
            self.table_crc = stream_crc32((value,), self.table_crc)
        elif r.name == "PATTERN_DATA":
            word = value & ((1 << PATTERN_WIDTH) - 1)
            self.table[self.scan_regs["PATTERN_ADDR"]] = word
            self.scan_regs["PATTERN_ADDR"] = (self.scan_regs["PATTERN_ADDR"] + 1) % PATTERN_ENTRIES
            self.pattern_crc = stream_crc32((word,), self.pattern_crc)

    def _read_scan(self, r):
        """A read of one of the antenna scan's registers (None: not one)."""
        if r.name == "AZIMUTH":
            return self.azimuth[r.channel]
        if r.name == "SCAN_CTRL":
            return self.scan_ctrl
        if r.name in self.scan_regs:
            return self.scan_regs[r.name]
        if r.name == "PATTERN":
            return self.pattern_reg
        if r.name == "PATTERN_CRC":
            return self.pattern_crc
        if r.name == "TABLE_CRC":
            return self.table_crc
        if r.name == "SCAN_STATUS":
            return self.beam.code | int(self.beam.track.learned) << r.field("learned").lsb
        if r.name == "ACP_PER_REV":
            return self.beam.per_rev
        return None

    def scan_event(self, arp: bool, acp: bool) -> None:
        """An ARP and/or an ACP (the ARP first) reaches the beam's generator
        before the next step (a block built with the scan)."""
        self.beam.event(arp, acp)

    def _pattern(self) -> PatternWords:
        ctrl = self.rmap.reg("PATTERN")
        return PatternWords(self.table, (self.pattern_reg >> ctrl.field("floor").lsb) & ((1 << PATTERN_WIDTH) - 1),
                            self.pattern_reg & ((1 << ctrl.field("shift").width) - 1))

    def write(self, addr, value):
        r = self.rmap.by_addr(addr)
        if r is None:
            return
        value = int(value) & 0xFFFFFFFF
        l = r.channel

        def fv(name):
            f = r.field(name)
            v = (value >> f.lsb) & ((1 << f.width) - 1)
            if f.clamp:
                v = min(max(v, f.clamp[0]), f.clamp[1])
            return v

        if self.c.scan:
            self._write_scan(r, value)

        if r.name == "CTRL":
            self.enable[l] = fv("enable")
            swap = fv("swap")
            if swap:
                # taken only for the stream just written, whole and intact
                swap = (self._stated[l] == {"BASE", "LENGTH", "CRC"}
                        and self.run_start == self.base_next[l] and self.run_count == self.len_next[l]
                        and self.run_crc == self.crc_next[l])
                self.rejected[l] = int(not swap)
                if swap:
                    self.crc_played[l] = self.crc_next[l]
            if not self.enable[l] and (swap or self.pending[l]):
                self._swap(l)
            elif swap:
                self.pending[l] = 1
        elif r.name == "LENGTH":
            self.len_next[l] = fv("length")
            self._stated[l].add("LENGTH")
        elif r.name == "PHASE_INC":
            self.inc_next[l] = fv("inc")
        elif r.name == "GAIN":
            self.gain[l] = fv("gain")
        elif r.name == "START":
            self.start_next[l] = fv("frac")
        elif r.name == "FOLLOW_SWITCH":
            # the first step after this one whose number has the low bits named
            ch, bits = fv("channel"), 1 << r.field("step").width
            step = self.steps + 1 + (fv("step") - self.steps - 1) % bits
            self.scheduled = (ch, step) if ch < self.c.channels else None
        elif r.name == "DELAY":
            self.delay_next[l] = fv("delay")
        elif r.name == "COMMON_DELAY":
            self.common_next = fv("delay")
        elif r.name == "APPLY":
            if fv("delays"):
                self.delay_act = list(self.delay_next)
                self.common_act = self.common_next
        elif r.name == "BASE":
            self.base_next[l] = fv("base")
            self._stated[l].add("BASE")
        elif r.name == "CRC":
            self.crc_next[l] = fv("crc")
            self._stated[l].add("CRC")
        elif r.name == "STREAM_ADDR":
            self.stream_addr = fv("addr")
            self.run_start, self.run_count, self.run_crc = self.stream_addr, 0, 0
        elif r.name == "POOL_CHECK":
            # the read-back of the pool from STREAM_ADDR on (the gateware's takes
            # a while, busy meanwhile; the model's answer is the one it ends with)
            self.check_crc = stream_crc32(self._pool_run(self.stream_addr, fv("words")))
        elif r.name == "STREAM_DATA":
            self.run_crc = stream_crc32((value,), self.run_crc)
            self.run_count = min(self.run_count + 1, self._count_max)
            # A playing stream's words are the host's to keep (the hardware's
            # cache may already hold them): the model reads them at the switch.
            if self.stream_addr < self.c.pool_words:
                self.pool[self.stream_addr] = value
            self.stream_addr = (self.stream_addr + 1) & self._amask

    def read(self, addr):
        r = self.rmap.by_addr(addr)
        if r is None:
            return 0
        l = r.channel
        if r.name == "CTRL":
            return (self.enable[l] | (self.pending[l] << 1) | (self.bank[l] << 2)
                    | (self.rejected[l] << 3))
        if r.name == "STATUS":
            v, self.overflow = self.overflow, 0
            if self.c.scan:
                v |= int(self.beam.track.lost) << r.field("arp_lost").lsb
            return v
        if self.c.scan and (v := self._read_scan(r)) is not None:
            return v
        stored = {"LENGTH": lambda: self.len_next[l], "PHASE_INC": lambda: self.inc_next[l],
                  "GAIN": lambda: self.gain[l], "START": lambda: self.start_next[l],
                  "DELAY": lambda: self.delay_next[l] | self.delay_act[l] << APPLIED_LSB,
                  "COMMON_DELAY": lambda: self.common_next | self.common_act << APPLIED_LSB,
                  "PLAYED": lambda: self.crc_played[l],
                  "BASE": lambda: self.base_next[l], "STREAM_ADDR": lambda: self.stream_addr,
                  "STREAM_CRC": lambda: self.run_crc,
                  "STREAM_COUNT": lambda: self.run_count, "POOL_CHECK_CRC": lambda: self.check_crc}
        if r.name in stored:
            return stored[r.name]()
        v = 0
        for f in r.fields:
            if f.access == "ro":
                v |= f.reset << f.lsb
        return v

    # ---- data path -------------------------------------------------------
    def _pool_run(self, start, n):
        """``n`` pool words from address ``start`` on, as the gateware reads
        them (addresses modulo the address width, 0 beyond the pool)."""
        addr = (start + np.arange(n)) & self._amask
        return np.where(addr < self.c.pool_words, self.pool[np.minimum(addr, self.c.pool_words - 1)], 0)

    def stream_of(self, l):
        """The active stream of channel ``l`` as the pool holds it (LENGTH words from BASE)."""
        return self._pool_run(self.base_act[l], self.len_act[l])

    def _words(self, l, phases):
        words, length = self._streams[l], self.len_act[l]
        if self.c.interpolation == "fir" and self._tables[l] is None:
            self._tables[l] = fir_table(*unpack_iq(words[:length]))
        return stream_words(self.c.interpolation, words, length, phases, self._tables[l])

    def _advance_streams(self, T):
        """Stream words produced from the states of the next T steps; updates state."""
        N = self.c.channels
        w = np.zeros((N, 2, T), dtype=np.int64)
        for l in range(N):
            k = 0
            while k < T:
                if self.refill[l]:
                    n = min(self.refill[l], T - k)     # muted, phase held
                    k += n
                    self.refill[l] -= n
                    continue
                length, inc, P = self.len_act[l], self.inc_act[l], self.phase[l]
                n = T - k
                if self.pending[l] and inc > 0:
                    # the step during which the wrap happens swaps banks
                    kw = -((P - length * ONE) // inc)     # ceil((L*ONE - P) / inc)
                    kw = max(kw - 1, 0)                   # index of that step
                    n = min(n, kw + 1)
                    swap_here = (kw + 1) <= (T - k)
                else:
                    swap_here = False
                ph = phase_sequence(P, inc, length, n)
                wi, wq = self._words(l, ph)
                w[l, 0, k:k + n], w[l, 1, k:k + n] = wi, wq
                k += n
                if swap_here:
                    self._swap(l)
                else:
                    self.phase[l] = (P + n * inc) % (length * ONE)
        return w

    def run(self, xi, xq):
        """Push input samples (signed ints); return the output samples (yi, yq)."""
        xi = np.asarray(xi, dtype=np.int64)
        xq = np.asarray(xq, dtype=np.int64)
        if self.scheduled is not None and 0 < self.scheduled[1] - self.steps < len(xi):
            k = self.scheduled[1] - self.steps           # a FOLLOW_SWITCH's step inside: run to it
            yi, yq = self.run(xi[:k], xq[:k])
            zi, zq = self.run(xi[k:], xq[k:])
            return np.concatenate([yi, zi]), np.concatenate([yq, zq])
        if self.scheduled is not None and self.scheduled[1] == self.steps:
            self._swap(self.scheduled[0])
            self.scheduled = None
        T = len(xi)
        self._x.append(np.stack([xi, xq]))
        self._d.append(np.repeat(np.array(self.delay_act + [self.common_act], dtype=np.int64)[:, None],
                                 T, axis=1))
        geff = np.array([g if e else 0 for g, e in zip(self.gain, self.enable)], dtype=np.int64)
        g = np.repeat(geff[:, None], T, axis=1)
        if self.c.scan and self.beam.mode != 0:
            beams = self.beam.take(T)
            offsets = beams[None, :] - np.array(self.azimuth, dtype=np.int64)[:, None]
            g = scanned_gain(g, pattern_lookup(self._pattern(), offsets))
        self._g.append(g)
        self._w.append(self._advance_streams(T))
        n0 = self.steps
        self.steps += T
        y = self._outputs(n0, self.steps)
        sat = y[2]
        if sat.any():
            self.overflow = 1
        return y[0], y[1]

    #: Registers whose writes change no output until a bank switch: the stream
    #: write path (the pool is read into a channel only when it switches).
    _UNTIMED = frozenset({"STREAM_ADDR", "STREAM_DATA"})
    #: Samples per :meth:`run` call of :meth:`run_with_writes`: the model looks
    #: back a bounded number of samples, so pieces keep memory small.
    CHUNK = 1 << 20

    def run_with_writes(self, xi, xq, writes):
        """Push input samples with register writes ``(step, addr, value)``
        (steps ascending), each taking effect from input sample ``step`` on;
        return the output samples (yi, yq) for all of ``xi``.

        Equal to calling :meth:`run` up to each write's step and then
        :meth:`write`, but STREAM_ADDR, and a stream word outside the stream
        of every pending switch, is applied without first running up to its
        step: no channel reads such a word before a later CTRL write, which
        does run up to its step (a playing stream's words are read at its
        switch). A load of many words then costs a few runs, not one per word.
        """
        xi = np.asarray(xi, dtype=np.int64)
        xq = np.asarray(xq, dtype=np.int64)
        ys_i, ys_q = [], []
        done = 0

        def run_to(stop):
            for k in range(done, stop, self.CHUNK):
                a, b = self.run(xi[k:min(stop, k + self.CHUNK)], xq[k:min(stop, k + self.CHUNK)])
                ys_i.append(a)
                ys_q.append(b)

        for step, addr, value in writes:
            if step > done:
                r = self.rmap.by_addr(addr)
                if r is not None and (r.name not in self._UNTIMED or self._read_at_switch(r.name)):
                    run_to(min(step, len(xi)))
                    done = min(step, len(xi))
            self.write(addr, value)
        run_to(len(xi))
        empty = np.zeros(0, dtype=np.int64)
        return (np.concatenate(ys_i) if ys_i else empty), (np.concatenate(ys_q) if ys_q else empty)

    def _read_at_switch(self, name):
        """Whether a STREAM_DATA write now lands in the stream of a pending
        switch (read from the pool when it is taken, so the write's step matters)."""
        if name != "STREAM_DATA":
            return False
        a = self.stream_addr
        return any(p and 0 <= a - self.base_next[l] < self.len_next[l] for l, p in enumerate(self.pending))

    def _outputs(self, n0, n1):
        """Outputs of absolute steps [n0, n1), computed over a window that
        starts at least ``_lookback`` steps earlier (or at step 0, exactly):
        entries early in a window that starts later are wrong but unused."""
        c, N = self.c, self.c.channels
        keep = max(0, n0 - self._lookback - self._base)        # drop what can no longer matter
        x = np.concatenate(self._x, axis=1)[:, keep:]
        d = np.concatenate(self._d, axis=1)[:, keep:]
        g = np.concatenate(self._g, axis=1)[:, keep:]
        w = np.concatenate(self._w, axis=2)[:, :, keep:]
        self._base += keep
        self._x, self._d, self._g, self._w = [x], [d], [g], [w]
        n0, n1 = n0 - self._base, n1 - self._base
        common = np.stack([delay_line(x[0], d[N], COMMON_LAG), delay_line(x[1], d[N], COMMON_LAG)])
        total = np.zeros((2, n1), dtype=np.int64)
        for l in range(N):
            t = np.stack([delay_line(common[0], d[l], WINDOW_LAG), delay_line(common[1], d[l], WINDOW_LAG)])
            pi, pq = cmult(t[0], t[1], w[l, 0], w[l, 1])
            total[0] += gain_scale(pi, g[l])
            total[1] += gain_scale(pq, g[l])
        yi, oi = saturate(total[0][n0:n1])
        yq, oq = saturate(total[1][n0:n1])
        return np.stack([yi, yq, (oi | oq).astype(np.int64)])
