"""cocotb testbench of the board's sample path (:mod:`rast.sim.board_io`).

Run from ``tests/test_cosim_board_io.py``; parameters arrive as JSON in
``RAST_TB_PARAMS``, results go to ``board_io.json`` in the run directory and
the pytest side checks them. The testbench makes the sample clock itself in
quarter periods, so every pin changes half way between clock edges:

* ADC pins: the I half of sample k is set a quarter period before rising
  edge k, the Q half a quarter period before the falling edge after it (the
  ``IDDRX1F`` takes I on rising edge k, Q on the falling edge: ADC pin sample k);
* DAC pins: read a quarter period after rising edge m (the I half, ``dac_iq``
  high) and a quarter period after the falling edge (the Q half, ``dac_iq``
  low): DAC pin sample m;
* UART ``rx``: 8N1 frames of :mod:`rast.model.hostproto`, bits of ``divisor``
  clocks changing at falling edges; ``tx`` is read at every falling edge and
  decoded after the run.

``steps``: per step, the register writes (sent as the host sends them), the
clocks to wait after the last acknowledgement, the impulse (I, Q) and the
number of DAC samples to record from the impulse's sample on.
"""

from __future__ import annotations

import json

import cocotb
from cocotb.triggers import Timer

from rast.model.hostproto import ACK, group_writes
from rast.sim.testbench import params, run_dir

QUARTER_NS = 2.5


def _uart_bits(frames, divisor: int, gap_bits: int = 2) -> list[int]:
    """Line level per clock for ``frames`` (8N1, LSB first, ``gap_bits`` idle between bytes)."""
    levels = []
    for frame in frames:
        for byte in frame:
            bits = [0] + [(byte >> b) & 1 for b in range(8)] + [1] * (1 + gap_bits)
            for bit in bits:
                levels += [bit] * divisor
    return levels


def _uart_decode(line: list[int], divisor: int) -> list[int]:
    """Bytes on a line sampled once per clock (8N1, idle high)."""
    out, k = [], 0
    while k < len(line):
        if line[k] == 0:
            mid = k + divisor // 2
            if mid + 9 * divisor >= len(line):
                break
            byte = sum(line[mid + (b + 1) * divisor] << b for b in range(8))
            out.append(byte)
            k = mid + 9 * divisor          # the stop bit's middle
        else:
            k += 1
    return out


def _signed16(v: int) -> int:
    return ((v & 0xFFFF) ^ 0x8000) - 0x8000


class _Bench:
    def __init__(self, dut, divisor: int):
        self.dut, self.divisor = dut, divisor
        self.cycle = 0
        self.adc = [(0, 0)]      # (I, Q) per cycle on the ADC pins; index = cycle
        self.rx = []             # line level per cycle
        self.tx = []
        self.dac = []            # (I, Q, iq during I, iq during Q) per cycle
        self.clocks = []         # (adc_clk, dac_clk) high and low halves, a few cycles

    def _adc(self, k):
        return self.adc[k] if k < len(self.adc) else (0, 0)

    async def clock(self, n: int = 1):
        """``n`` sample clocks: rising edge, Q half, falling edge, next I half."""
        d = self.dut
        for _ in range(n):
            k = self.cycle
            d.clk.value = 1
            await Timer(QUARTER_NS, "ns")
            d.adc_data.value = self._adc(k)[1] & 0xFFFF
            hi = (int(d.dac_data.value), int(d.dac_iq.value), int(d.adc_clk.value), int(d.dac_clk.value))
            await Timer(QUARTER_NS, "ns")
            d.clk.value = 0
            d.rx.value = self.rx[k] if k < len(self.rx) else 1
            await Timer(QUARTER_NS, "ns")
            d.adc_data.value = self._adc(k + 1)[0] & 0xFFFF
            lo = (int(d.dac_data.value), int(d.dac_iq.value), int(d.adc_clk.value), int(d.dac_clk.value))
            self.tx.append(int(d.tx.value))
            self.dac.append((_signed16(hi[0]), _signed16(lo[0]), hi[1], lo[1]))
            if len(self.clocks) < 64:
                self.clocks.append((hi[2], lo[2], hi[3], lo[3]))
            await Timer(QUARTER_NS, "ns")
            self.cycle += 1

    def acks(self, start: int = 0) -> int:
        return sum(1 for b in _uart_decode(self.tx[start:], self.divisor) if b == ACK)


@cocotb.test()
async def board_io(dut):
    p = params()
    bench = _Bench(dut, p["divisor"])
    dut.clk.value = 0
    dut.rst.value = 1
    dut.rx.value = 1
    dut.adc_data.value = 0
    await Timer(QUARTER_NS, "ns")
    await bench.clock(4)
    dut.rst.value = 0
    await bench.clock(8)
    results, frames_sent = [], 0
    for step in p["steps"]:
        frames = group_writes([tuple(w) for w in step["writes"]])
        frames_sent += len(frames)
        base = len(bench.tx)                 # the line is idle here: every earlier reply is in
        start = bench.cycle + 2
        bench.rx += [1] * (start - len(bench.rx))
        bench.rx += _uart_bits(frames, bench.divisor)
        limit = len(bench.rx) + 200 * bench.divisor
        while (got := bench.acks(base)) < len(frames):
            if bench.cycle > limit:
                raise AssertionError(f"{got} of {len(frames)} acknowledgements by cycle "
                                     f"{bench.cycle}: the bridge did not take the writes")
            await bench.clock(8 * bench.divisor)
        await bench.clock(step["settle"])
        t0 = bench.cycle + 2
        bench.adc += [(0, 0)] * (t0 - len(bench.adc))
        bench.adc.append(tuple(step["impulse"]))
        await bench.clock(t0 + step["window"] - bench.cycle)
        rec = bench.dac[t0:t0 + step["window"]]
        results.append({"impulse_cycle": t0,
                        "nonzero": [[m, i, q] for m, (i, q, _, _) in enumerate(rec) if i or q],
                        "iq_marker": sorted({(a, b) for _, _, a, b in rec})})
    replies = _uart_decode(bench.tx, bench.divisor)
    report = {"steps": results, "acks": replies.count(ACK), "replies": len(replies),
              "frames": frames_sent,
              "overflow": int(dut.overflow.value), "clocks": sorted(set(bench.clocks[16:]))}
    (run_dir() / "board_io.json").write_text(json.dumps(report))
