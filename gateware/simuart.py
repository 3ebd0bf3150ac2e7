"""A UART transport into the Amaranth simulator, for :class:`rast.model.contract.hostproto.HostBridge`.

``SimUART(dut, divisor)`` runs a :class:`~amaranth.sim.Simulator` of ``dut``
(a component with ``rx``/``tx`` UART lines in the ``sync`` domain) step by
step: ``write`` queues bytes that a simulation process shifts onto ``rx``;
``read(n)`` advances the simulation until ``n`` bytes have been decoded from
``tx`` (or ``timeout_cycles`` passed), exactly as a serial port would answer.
Extra processes (sample sources, bus monitors) can be added before the first
access with :meth:`add_process`.
"""

from collections import deque

from amaranth.sim import Simulator

__all__ = ["SimUART"]

CLOCK_PERIOD = 1e-8


class SimUART:
    def __init__(self, dut, divisor, *, timeout_cycles=None):
        self.dut = dut
        self.divisor = divisor
        self.timeout_cycles = timeout_cycles or 200 * divisor
        self._tx_queue = deque()
        self._rx_bytes = deque()
        self.cycles = 0
        self.line_idle = True
        self.sim = Simulator(dut)
        self.sim.add_clock(CLOCK_PERIOD)
        self.sim.add_process(self._drive)
        self.sim.add_process(self._capture)
        self._started = False

    def add_process(self, proc):
        if self._started:
            raise RuntimeError("Processes must be added before the first access")
        self.sim.add_process(proc)

    async def _drive(self, ctx):
        d = self.divisor
        ctx.set(self.dut.rx, 1)
        while True:
            if not self._tx_queue:
                self.line_idle = True
                await ctx.tick()
                continue
            self.line_idle = False
            byte = self._tx_queue.popleft()
            for bit in [0] + [(byte >> k) & 1 for k in range(8)] + [1]:
                ctx.set(self.dut.rx, bit)
                await ctx.tick().repeat(d)

    async def _capture(self, ctx):
        d = self.divisor
        while True:
            _, _, tx = await ctx.tick().sample(self.dut.tx)
            if tx:
                continue
            await ctx.tick().repeat(d // 2)          # middle of the start bit
            byte = 0
            for k in range(8):
                bit, = await ctx.tick().sample(self.dut.tx).repeat(d)
                byte |= (bit & 1) << k
            await ctx.tick().repeat(d)               # stop bit
            self._rx_bytes.append(byte)

    def run_cycles(self, n):
        self._started = True
        self.cycles += n
        self.sim.run_until(self.cycles * CLOCK_PERIOD)

    def write(self, data):
        self._tx_queue.extend(bytes(data))

    def read(self, n):
        waited = 0
        chunk = max(8, self.divisor)
        while len(self._rx_bytes) < n:
            # Time runs only while something can still answer: bytes in flight
            # count towards the wait only once the host has nothing left to send.
            self.run_cycles(chunk)
            if not self._tx_queue and self.line_idle:
                waited += chunk
                if waited > self.timeout_cycles:
                    break
        k = min(n, len(self._rx_bytes))
        return bytes(self._rx_bytes.popleft() for _ in range(k))

    def idle(self, cycles):
        """Let the line stay quiet (after the queue drains) for ``cycles``."""
        while self._tx_queue or not self.line_idle:
            self.run_cycles(self.divisor)
        self.run_cycles(cycles)

    def drain(self):
        self._rx_bytes.clear()
