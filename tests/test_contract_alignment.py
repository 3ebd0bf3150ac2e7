"""The gateware against a model written only from docs/fixed_point.md
("Alignment", "Operations", "The stream word at the multiplier"), in plain
Python integers: not rast.model.contract.datapath. Driven only through the documented
registers; a GAIN write mid-run checks when a gain shows."""

import numpy as np
import pytest

from rast.hdl.replay_top import WindFarmReplay
from rast.model.contract.fixedpoint import fir_coefficients, pack_iq
from rast.model.contract.powerup import ChannelInit

from hdl_harness import run_replay


def rhu(v, s):
    return (v + (1 << (s - 1))) >> s


def sat(v, bits=16):
    return max(-(1 << (bits - 1)), min((1 << (bits - 1)) - 1, v))


class DocReader:
    """docs/fixed_point.md, read literally."""

    def __init__(self, interpolation, inits, latency, writes, common, slots):
        self.interp, self.inits, self.L, self.N = interpolation, inits, latency, len(inits)
        self.common, self.M = common, slots
        self.P = -(-self.N // slots)                    # pipelines
        self.writes = writes          # {channel: [(input k, new gain)]}, in order
        self.c = fir_coefficients()

    def word(self, l, s):
        ini = self.inits[l]
        w = [(int(v) & 0xFFFF, int(v) >> 16 & 0xFFFF) for v in ini.words]
        w = [(a - (a >> 15 << 16), b - (b >> 15 << 16)) for a, b in w]   # signed 16-bit parts
        L, inc = len(w), ini.phase_increment
        if s < 0:
            return 0, 0
        # muted (phase held at 0) while the caches fill after reset: the
        # restart, 13 words per channel, one scan of P periods each, 20 clocks
        # more, one to spare; the FIR 48 more
        mute = 1 + 13 * self.P + -(-20 // self.M) + 1 + (48 if self.interp == "fir" else 0)
        if s < mute:
            return 0, 0
        s -= mute
        P = s * inc % (L << 32)
        idx = P >> 32
        if self.interp == "hold":
            return w[idx]
        if self.interp == "linear":
            f = (P & 0xFFFFFFFF) >> 16
            nxt = w[(idx + 1) % L]
            return tuple(w[idx][k] + rhu((nxt[k] - w[idx][k]) * f, 16) for k in (0, 1))
        J = P >> 27

        def U(j):
            j %= 32 * L
            base, p = j >> 5, j & 31
            return tuple(sat(rhu(sum(self.c[p][k] * w[(base + 5 - k) % L][part] for k in range(10)), 16))
                         for part in (0, 1))
        f = (P >> 11) & 0xFFFF
        a, b = U(J), U(J + 1)
        return tuple(a[k] + rhu((b[k] - a[k]) * f, 16) for k in (0, 1))

    def gain(self, l, k):
        g = self.inits[l].gain
        for at, value in self.writes.get(l, []):
            if at <= k:
                g = value
        return g

    def output(self, xi, xq, n):
        yi = yq = 0
        for l in range(self.N):
            k = n - self.L - self.common - self.inits[l].delay
            x = (int(xi[k]), int(xq[k])) if k >= 0 else (0, 0)
            mi, mq = self.word(l, n)
            pi, pq = rhu(x[0] * mi - x[1] * mq, 15), rhu(x[0] * mq + x[1] * mi, 15)
            g = self.gain(l, n)
            yi += rhu(pi * g, 16)
            yq += rhu(pq * g, 16)
        return sat(yi), sat(yq)


@pytest.mark.parametrize("interpolation, slots", [("hold", 1), ("linear", 1), ("fir", 1), ("fir", 2),
                                                  ("hold", 3)])
def test_gateware_matches_a_reading_of_the_docs(interpolation, slots):
    rng = np.random.default_rng({"hold": 1, "linear": 2, "fir": 3}[interpolation])
    N, depth = 2, 16
    inits = []
    for l in range(N):
        length = int(rng.integers(8, depth + 1))
        words = pack_iq(rng.integers(-30000, 30000, length), rng.integers(-30000, 30000, length))
        inc = int(rng.integers(1 << 22, 5_592_405)) if interpolation == "fir" else int(rng.integers(1 << 29, 1 << 31))  # within the clamps for N = 2
        inits.append(ChannelInit(tuple(int(w) for w in words), inc, int(rng.integers(1 << 15, 1 << 17)),
                                 int(rng.integers(0, 5)), True, base=depth * l))
    common = int(rng.integers(0, 9))
    dut = WindFarmReplay(N, slots=slots, init=inits, pool_words=N * depth, max_delay=8, max_tap=4,
                         interpolation=interpolation, init_common_delay=common)
    a = dut.register_map.addr
    T = 700
    xi, xq = rng.integers(-32768, 32768, T), rng.integers(-32768, 32768, T)
    writes = {0: [(350, 70000)], 1: [(400, 12345)]}
    ops = [(k, "w", a("GAIN", l), g) for l, ws in writes.items() for k, g in ws]
    hi, hq, _ = run_replay(dut, xi, xq, ops, valid=(1, 1, 0), hold=True)
    doc = DocReader(interpolation, inits, dut.latency, writes, common, slots)
    for n in range(T):
        assert (int(hi[n]), int(hq[n])) == doc.output(xi, xq, n), f"output {n}"


@pytest.mark.slow
@pytest.mark.parametrize("N, slots", [(3, 1), (5, 1), (5, 2), (7, 3)])
def test_gain_write_shows_at_output_k(N, slots):
    """What the docs state: a GAIN write between inputs k - 1 and k shows from
    output k on, for every channel whatever its slot, seen directly (a
    constant stream and input, hold)."""
    word = int(pack_iq([16384], [0])[0])
    for l in range(N):
        inits = [ChannelInit((word,) * 8, 0, 0, 0, True) for _ in range(N)]
        dut = WindFarmReplay(N, slots=slots, init=inits, pool_words=16, max_delay=4, max_tap=2,
                             interpolation="hold")
        R = dut.contract.refill_samples          # muted while the caches fill after reset
        T, k = R + 80, R + 40
        hi, _, _ = run_replay(dut, np.full(T, 16384), np.zeros(T), [(k, "w", dut.register_map.addr("GAIN", l), 1 << 16)],
                              hold=True)
        assert int(np.nonzero(hi)[0][0]) == k, f"channel {l}"
