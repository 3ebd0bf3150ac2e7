"""Memory-mapped register file, generated from ``rast.model.regmap``."""

from amaranth.hdl import Module, Signal, Const, Mux, Cat
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..model.regmap import RegisterMap
from ..model.fixedpoint import STREAM_WIDTH

__all__ = ["BusSignature", "RegisterFile"]


class BusSignature(wiring.Signature):
    """A minimal register bus, seen from the host (initiator).

    One access per cycle: ``w_stb`` writes ``w_data`` at ``addr``; ``r_stb``
    reads ``addr``, the value appears on ``r_data`` in the next cycle.
    """

    def __init__(self, addr_width, data_width=32):
        super().__init__({
            "addr": Out(addr_width),
            "w_stb": Out(1),
            "w_data": Out(data_width),
            "r_stb": Out(1),
            "r_data": In(data_width),
        })


class RegisterFile(wiring.Component):
    """Storage, strobes and read-back for every register of ``rmap``.

    Storage (``rw`` fields) is created generically from the description;
    the commands (``wo`` fields) and the sticky status are wired by name.

    Members
    -------
    bus : In(BusSignature)
    enable, gain, delay, length, increment : Out, one per channel
        ``delay`` is the applied tap (copied from the DELAY registers by APPLY).
    common_delay : Out
        The applied common delay (copied from COMMON_DELAY by APPLY).
    swap_req, swap_force : Out(1) per channel, strobes of a CTRL write
    base : Out(pool address) per channel
    pending_next, bank_next : In(1) per channel, from the stream replays
    wr_en : Out(1), wr_addr : Out(pool address), wr_data : Out(32)
        Registered pool write (one cycle after the STREAM_DATA write).
    overflow_set : In(1)
        An output sample saturated in this cycle.
    overflow : Out(1)
        The sticky overflow flag.
    """

    def __init__(self, rmap: RegisterMap):
        if not isinstance(rmap, RegisterMap):
            raise TypeError(f"Register map must be a RegisterMap, not {rmap!r}")
        self._rmap = rmap
        c = rmap.contract
        N = c.channels
        self._widths = {name: rmap.reg(name, 0).field(fname).width for name, fname in
                        (("GAIN", "gain"), ("LENGTH", "length"), ("PHASE_INC", "inc"),
                                           ("BASE", "base"))}
        self._dw = rmap.reg("DELAY", 0).field("delay").width
        self._cw = rmap.reg("COMMON_DELAY").field("delay").width
        super().__init__({
            "bus": In(BusSignature(rmap.addr_width)),
            "enable": Out(1).array(N),
            "gain": Out(self._widths["GAIN"]).array(N),
            "length": Out(self._widths["LENGTH"]).array(N),
            "increment": Out(self._widths["PHASE_INC"]).array(N),
            "base": Out(self._widths["BASE"]).array(N),
            "delay": Out(self._dw).array(N),
            "common_delay": Out(self._cw),
            "swap_req": Out(1).array(N),
            "swap_force": Out(1).array(N),
            "pending_next": In(1).array(N),
            "bank_next": In(1).array(N),
            "wr_en": Out(1),
            "wr_addr": Out(c.pool_address_width),
            "wr_data": Out(2 * STREAM_WIDTH),
            "overflow_set": In(1),
            "overflow": Out(1),
        })

    @property
    def rmap(self):
        return self._rmap

    def elaborate(self, platform):
        m = Module()
        rmap, bus = self._rmap, self.bus
        c = rmap.contract
        N = c.channels
        storage = {}          # (reg name, channel, field name) -> Signal
        for r in rmap.registers:
            for f in r.fields:
                if f.access == "rw":
                    storage[(r.name, r.channel, f.name)] = Signal(
                        f.width, init=f.reset, name=f"{r.name.lower()}{'' if r.channel is None else r.channel}_{f.name}")

        def wsel(r):
            return bus.w_stb & (bus.addr == r.addr)

        # Generic rw storage, masked then clamped.
        for r in rmap.registers:
            for f in r.fields:
                if f.access != "rw":
                    continue
                sig = storage[(r.name, r.channel, f.name)]
                v = bus.w_data[f.lsb:f.lsb + f.width]
                if f.clamp:
                    lo, hi = f.clamp
                    if hi < (1 << f.width) - 1:
                        v = Mux(v > hi, hi, v)
                    if lo > 0:
                        v = Mux(v < lo, lo, v)
                with m.If(wsel(r)):
                    m.d.sync += sig.eq(v)

        # Per-channel outputs and commands.
        apply = wsel(rmap.reg("APPLY")) & bus.w_data[0]
        for l in range(N):
            ctrl = rmap.reg("CTRL", l)
            en_written = bus.w_data[ctrl.field("enable").lsb]
            swap_written = bus.w_data[ctrl.field("swap").lsb]
            force = wsel(ctrl) & ~en_written & (swap_written | self.pending_next[l])
            m.d.comb += [
                self.enable[l].eq(storage[("CTRL", l, "enable")]),
                self.gain[l].eq(storage[("GAIN", l, "gain")]),
                self.length[l].eq(storage[("LENGTH", l, "length")]),
                self.increment[l].eq(storage[("PHASE_INC", l, "inc")]),
                self.base[l].eq(storage[("BASE", l, "base")]),
                self.swap_force[l].eq(force),
                self.swap_req[l].eq(wsel(ctrl) & swap_written & ~force),
            ]
            d = rmap.reg("DELAY", l)
            applied = Signal(self._dw, init=d.fields[0].reset, name=f"delay{l}_applied")
            with m.If(apply):
                m.d.sync += applied.eq(storage[("DELAY", l, "delay")])
            m.d.comb += self.delay[l].eq(applied)

        common = rmap.reg("COMMON_DELAY")
        applied = Signal(self._cw, init=common.fields[0].reset, name="common_delay_applied")
        with m.If(apply):
            m.d.sync += applied.eq(storage[("COMMON_DELAY", None, "delay")])
        m.d.comb += self.common_delay.eq(applied)

        # Pool write path, registered.
        addr = storage[("STREAM_ADDR", None, "addr")]
        data_w = wsel(rmap.reg("STREAM_DATA"))
        m.d.sync += self.wr_en.eq(data_w)
        with m.If(data_w):
            m.d.sync += [self.wr_addr.eq(addr), self.wr_data.eq(bus.w_data),
                         addr.eq(addr + 1)]

        # Sticky overflow, cleared by reading STATUS (a saturation in the
        # same cycle is reported by that read and cleared with it).
        status = rmap.reg("STATUS")
        flag = self.overflow
        rsel_status = bus.r_stb & (bus.addr == status.addr)
        m.d.sync += flag.eq(Mux(rsel_status, 0, flag | self.overflow_set))

        # Read-back: registered; live bits show the state after this cycle.
        hooks = {("STATUS", None, "overflow"): flag | self.overflow_set}
        for l in range(N):
            hooks[("CTRL", l, "swap")] = self.pending_next[l]
            hooks[("CTRL", l, "bank")] = self.bank_next[l]
        with m.If(bus.r_stb):
            with m.Switch(bus.addr):
                for r in rmap.registers:
                    with m.Case(r.addr):
                        parts = []
                        for f in r.fields:
                            key = (r.name, r.channel, f.name)
                            if key in storage:
                                v = storage[key]
                            elif key in hooks:
                                v = hooks[key]
                            elif f.access == "ro":
                                v = Const(f.reset, f.width)
                            else:
                                v = Const(0, f.width)
                            parts.append((f.lsb, v))
                        word = Const(0, 32)
                        for lsb, v in parts:
                            word = word | (v.as_unsigned() << lsb)
                        m.d.sync += bus.r_data.eq(word[:32])
                with m.Default():
                    m.d.sync += bus.r_data.eq(0)
        return m
