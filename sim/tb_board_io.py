"""cocotb testbench of the board's sample path (:mod:`rast.sim.board_io`).

Run from ``tests/test_cosim_board_io.py``; parameters arrive as JSON in
``RAST_TB_PARAMS``, results go to ``board_io.json`` in the run directory and
the pytest side checks them. The testbench makes the fabric clock itself in
quarter periods and plays the converters from the pins, as real ones would
see them: the forwarded ``adc_clk`` (the same pattern as ``dac_clk``) is
high for the first half of each sample, ``slots`` half fabric clocks, low
for the second; pin sample k begins at its k-th rising edge.

* ADC pins: centre-aligned with ``adc_clk``: the I half of sample k is set
  in the middle of the low phase before its rising edge, the Q half in the
  middle of its high phase (the ``IDDRX1F`` takes I on the rising edge, Q on
  the falling edge);
* DAC pins: read in the middle of each phase of ``dac_clk``: the I half
  (``dac_iq`` high) in the high phase, the Q half in the low phase; and in
  every half clock of it, to see that the pins hold one value per phase;
* UART ``rx``: 8N1 frames of :mod:`rast.model.contract.hostproto`, bits of ``divisor``
  fabric clocks changing at falling edges; ``tx`` is read at every falling
  edge and decoded after the run.

``steps``: per step, the register writes (sent as the host sends them), the
samples to wait after the last acknowledgement, the impulse (I, Q) and the
number of DAC samples to record from the impulse's sample on.
"""

from __future__ import annotations

import json

import cocotb
from cocotb.triggers import Timer

from rast.model.contract.hostproto import ACK, group_writes
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
    def __init__(self, dut, divisor: int, slots: int):
        self.dut, self.divisor, self.slots = dut, divisor, slots
        self.cycle = 0           # fabric clocks
        self.sample = -1         # pin samples: rising edges of adc_clk seen
        self.adc = {}            # (I, Q) per pin sample
        self.rx = []             # line level per fabric clock
        self.tx = []
        self.dac = {}            # pin sample -> [I, Q, iq during I, iq during Q]
        self.phase_values = {}   # pin sample -> (the DAC's values in the high phase, in the low phase)
        self.pattern = []        # (adc_clk, dac_clk, dac_iq) per half clock, a few periods
        self._level = 0          # adc_clk's level in the last half clock
        self._half = 0           # half clocks since its last change
        self._mid = (slots - 1) // 2    # the half clock in the middle of a phase

    def _adc(self, k):
        return self.adc.get(k, (0, 0))

    def _half_clock(self):
        """In the middle of a half fabric clock: follow the pins' clock, play
        the ADC's next half, read the DAC's."""
        d = self.dut
        level = int(d.adc_clk.value)
        if level != self._level:
            self._level, self._half = level, 0
            if level:
                self.sample += 1
        else:
            self._half += 1
        if self.cycle >= 64 and len(self.pattern) < 8 * self.slots:
            self.pattern.append((level, int(d.dac_clk.value), int(d.dac_iq.value)))
        if self.sample >= 0:
            seen = self.phase_values.setdefault(self.sample, (set(), set()))
            seen[0 if level else 1].add(int(d.dac_data.value))
        if self._half == self._mid and self.sample >= 0:
            k = self.sample
            rec = self.dac.setdefault(k, [0, 0, 0, 0])
            if level:          # high phase: DAC's I half; the ADC's Q half of sample k
                rec[0], rec[2] = _signed16(int(d.dac_data.value)), int(d.dac_iq.value)
                d.adc_data.value = self._adc(k)[1] & 0xFFFF
            else:              # low phase: DAC's Q half; the ADC's I half of sample k + 1
                rec[1], rec[3] = _signed16(int(d.dac_data.value)), int(d.dac_iq.value)
                d.adc_data.value = self._adc(k + 1)[0] & 0xFFFF

    async def clock(self, n: int = 1):
        """``n`` fabric clocks: rising edge, middle, falling edge, middle."""
        d = self.dut
        for _ in range(n):
            k = self.cycle
            d.clk.value = 1
            await Timer(QUARTER_NS, "ns")
            self._half_clock()
            await Timer(QUARTER_NS, "ns")
            d.clk.value = 0
            d.rx.value = self.rx[k] if k < len(self.rx) else 1
            await Timer(QUARTER_NS, "ns")
            self._half_clock()
            self.tx.append(int(d.tx.value))
            await Timer(QUARTER_NS, "ns")
            self.cycle += 1

    async def samples(self, n: int):
        """Until ``n`` more pin samples have begun."""
        end = self.sample + n
        while self.sample < end:
            await self.clock()

    def acks(self, start: int = 0) -> int:
        return sum(1 for b in _uart_decode(self.tx[start:], self.divisor) if b == ACK)


@cocotb.test()
async def board_io(dut):
    p = params()
    bench = _Bench(dut, p["divisor"], p["slots"])
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
        await bench.samples(step["settle"])
        t0 = bench.sample + 2
        bench.adc[t0] = tuple(step["impulse"])
        await bench.samples(t0 + step["window"] + 1 - bench.sample)
        rec = [bench.dac.get(t0 + m, [0, 0, 0, 0]) for m in range(step["window"])]
        results.append({"impulse_sample": t0,
                        "nonzero": [[m, i, q] for m, (i, q, _, _) in enumerate(rec) if i or q],
                        "iq_marker": sorted({(a, b) for _, _, a, b in rec}),
                        "unsteady": [m for m in range(step["window"])
                                     if any(len(v) > 1 for v in bench.phase_values.get(t0 + m, ()))]})
    replies = _uart_decode(bench.tx, bench.divisor)
    report = {"steps": results, "acks": replies.count(ACK), "replies": len(replies),
              "frames": frames_sent, "overflow": int(dut.overflow.value),
              "pattern": bench.pattern}
    (run_dir() / "board_io.json").write_text(json.dumps(report))
