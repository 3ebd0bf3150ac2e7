"""ECP5 clocking: an ``EHXPLLL`` making the fabric clock, and optionally more
clocks, from the board clock.

:func:`pll_params` searches the divider settings the way ``ecppll`` does
(reference divider, feedback divider, output divider; the PLL's frequency
limits from the ECP5 data sheet, as ecppll uses them) and :class:`ECP5PLL`
instantiates the primitive with the feedback taken from ``CLKOP``.

Secondary outputs (``CLKOS``, ``CLKOS2``, ``CLKOS3``) divide the same VCO,
so the search keeps only VCO frequencies that are a common multiple of every
requested output. Their phase against ``CLKOP`` is set statically in VCO
cycles: an output of divider ``D`` is at 0° with ``CPHASE = D - 1`` (the
value Lattice's tools write and this module writes for ``CLKOP``), each
further ``CPHASE`` step delays it by one VCO period (360° / ``D``) and each
``FPHASE`` step by an eighth of one. LiteX's ``ECP5PLL`` derives
``CPHASE`` the same way (``FPHASE`` 0); ecppll's offsets differ by a common
constant, which leaves the outputs' relative phase the same.
"""

from dataclasses import dataclass

from amaranth.hdl import Elaboratable, Module, Signal, ClockDomain, Instance
from amaranth.lib.cdc import AsyncFFSynchronizer, ResetSynchronizer

__all__ = ["PLLParams", "PLLOutput", "pll_params", "ECP5PLL", "SECONDARY_PORTS"]

# ECP5 EHXPLLL limits (ecppll, FPGA-DS-02012): MHz.
PFD_MIN, PFD_MAX = 3.125, 400.0
VCO_MIN, VCO_MAX = 400.0, 800.0
OUT_MIN, OUT_MAX = 3.125, 400.0
#: Output divider and coarse phase range of the EHXPLLL (7-bit fields).
DIV_MAX = 128
CPHASE_MAX = 127
#: The secondary outputs, in the order they are given out.
SECONDARY_PORTS = ("CLKOS", "CLKOS2", "CLKOS3")


@dataclass(frozen=True)
class PLLOutput:
    """A secondary output: ``domain`` at ``f_out_mhz`` (``vco / div``), shifted
    ``phase_deg`` against CLKOP (the requested phase rounded to 1/8 VCO cycle)."""
    port: str                # CLKOS, CLKOS2 or CLKOS3
    domain: str
    f_out_mhz: float         # achieved
    div: int                 # CLKOSn_DIV
    cphase: int              # CLKOSn_CPHASE
    fphase: int              # CLKOSn_FPHASE

    @property
    def phase_deg(self) -> float:
        """Achieved phase against CLKOP, degrees of this output's period."""
        return 360.0 * ((self.cphase - (self.div - 1)) + self.fphase / 8) / self.div


@dataclass(frozen=True)
class PLLParams:
    f_in_mhz: float
    f_out_mhz: float         # achieved
    refclk_div: int          # CLKI_DIV
    feedback_div: int        # CLKFB_DIV
    output_div: int          # CLKOP_DIV
    outputs: tuple = ()      # PLLOutput, secondary outputs

    @property
    def f_vco_mhz(self) -> float:
        return self.f_out_mhz * self.output_div

    @property
    def f_pfd_mhz(self) -> float:
        return self.f_in_mhz / self.refclk_div


def _phase_setting(div, phase_deg):
    """(CPHASE, FPHASE) for ``phase_deg`` on an output of divider ``div``."""
    eighths = round(phase_deg / 360.0 * div * 8)
    return div - 1 + eighths // 8, eighths % 8


def _check_outputs(outputs):
    """``outputs`` as a tuple of (domain, MHz, degrees), checked."""
    if not isinstance(outputs, (list, tuple)):
        raise TypeError(f"PLL outputs must be a sequence of (domain, MHz, degrees), not {outputs!r}")
    if len(outputs) > len(SECONDARY_PORTS):
        raise ValueError(f"The ECP5 PLL has {len(SECONDARY_PORTS)} secondary outputs "
                         f"({', '.join(SECONDARY_PORTS)}); {len(outputs)} were asked")
    out, seen = [], set()
    for spec in outputs:
        if not (isinstance(spec, (list, tuple)) and len(spec) in (2, 3)):
            raise TypeError(f"PLL output must be (domain, MHz) or (domain, MHz, degrees), not {spec!r}")
        domain, f, phase = (*spec, 0.0) if len(spec) == 2 else spec
        if not (isinstance(domain, str) and domain):
            raise TypeError(f"PLL output domain must be a domain name, not {domain!r}")
        if domain in seen:
            raise ValueError(f"PLL output domain {domain!r} is given twice")
        seen.add(domain)
        if not isinstance(f, (int, float)) or isinstance(f, bool) or f <= 0:
            raise TypeError(f"PLL output {domain!r}: frequency must be a positive number of MHz, not {f!r}")
        if not OUT_MIN <= f <= OUT_MAX:
            raise ValueError(f"PLL output {domain!r}: frequency must be in [{OUT_MIN}, {OUT_MAX}] MHz, "
                             f"not {f!r}")
        if not isinstance(phase, (int, float)) or isinstance(phase, bool) or not 0 <= phase < 360:
            raise ValueError(f"PLL output {domain!r}: phase must be a number of degrees in [0, 360), "
                             f"not {phase!r}")
        out.append((domain, float(f), float(phase)))
    return tuple(out)


def pll_params(f_in_mhz: float, f_out_mhz: float, tolerance_mhz: float = 0.01, *,
               outputs=()) -> PLLParams:
    """Divider settings giving ``f_out_mhz`` from ``f_in_mhz`` (feedback from CLKOP).

    ``f_out = f_in * feedback_div / refclk_div``, ``f_vco = f_out * output_div``.
    Among the settings closest to the request, the one with the VCO nearest
    600 MHz is taken (ecppll's choice). ``outputs``: secondary outputs as
    ``(domain, MHz)`` or ``(domain, MHz, degrees)``, given out as CLKOS,
    CLKOS2, CLKOS3 in that order, each ``vco / div`` within ``tolerance_mhz``
    (the VCO is then a common multiple of all the outputs). Raises
    ``ValueError`` when nothing is within ``tolerance_mhz``.
    """
    for name, v in (("Input frequency", f_in_mhz), ("Output frequency", f_out_mhz)):
        if not isinstance(v, (int, float)) or isinstance(v, bool) or v <= 0:
            raise TypeError(f"{name} must be a positive number of MHz, not {v!r}")
    if not OUT_MIN <= f_out_mhz <= OUT_MAX:
        raise ValueError(f"PLL output frequency must be in [{OUT_MIN}, {OUT_MAX}] MHz, not {f_out_mhz!r}")
    if not isinstance(tolerance_mhz, (int, float)) or isinstance(tolerance_mhz, bool) or tolerance_mhz < 0:
        raise TypeError(f"PLL tolerance must be a non-negative number of MHz, not {tolerance_mhz!r}")
    specs = _check_outputs(outputs)
    best = None
    for ref in range(1, 129):
        pfd = f_in_mhz / ref
        if not PFD_MIN <= pfd <= PFD_MAX:
            continue
        for fb in range(1, 81):
            out = pfd * fb
            if not OUT_MIN <= out <= OUT_MAX:
                continue
            for od in range(1, DIV_MAX + 1):
                vco = out * od
                if not VCO_MIN <= vco <= VCO_MAX:
                    continue
                divs, worst = [], 0.0
                for _, f, _ in specs:
                    d = min(max(1, round(vco / f)), DIV_MAX)
                    divs.append(d)
                    worst = max(worst, abs(vco / d - f))
                key = (round(max(abs(out - f_out_mhz), worst), 9), abs(vco - 600.0))
                if best is None or key < best[0]:
                    best = (key, ref, fb, od, divs)
    if best is None or best[0][0] > tolerance_mhz:
        if best is None:
            got = "nothing"
        else:
            _, ref, fb, od, divs = best
            vco = f_in_mhz / ref * fb * od
            got = ", ".join([f"{vco / od:.4f} MHz"] + [f"{d}: {vco / dv:.4f} MHz"
                                                       for (d, _, _), dv in zip(specs, divs)])
        want = " and ".join([f"{f_out_mhz:g} MHz"] + [f"{d}: {f:g} MHz" for d, f, _ in specs])
        raise ValueError(f"The ECP5 PLL cannot make {want} from {f_in_mhz:g} MHz (closest: {got})")
    _, ref, fb, od, divs = best
    vco = f_in_mhz / ref * fb * od
    secondary = []
    for port, (domain, _, phase), d in zip(SECONDARY_PORTS, specs, divs):
        cphase, fphase = _phase_setting(d, phase)
        if cphase > CPHASE_MAX:
            raise ValueError(f"PLL output {domain!r}: a phase of {phase:g} degrees at divider {d} needs "
                             f"CPHASE {cphase}, beyond the PLL's {CPHASE_MAX}")
        secondary.append(PLLOutput(port, domain, vco / d, d, cphase, fphase))
    return PLLParams(f_in_mhz, vco / od, ref, fb, od, tuple(secondary))


class ECP5PLL(Elaboratable):
    """Clock domain ``domain`` from an ``EHXPLLL`` (CLKOP, which is also the
    feedback), and one more domain per secondary output of ``params``; each
    domain is held in reset until the PLL locks (a reset synchronizer on
    the lock, in that domain; the main domain's reset then goes through a
    ``DCCA`` onto a global network).

    Parameters
    ----------
    clk_in : Signal
        The board clock (after its input buffer).
    params : PLLParams
    domain : str
        Name of the clock domain created from CLKOP.

    Members
    -------
    locked : Signal
        The PLL's ``LOCK`` output.
    """

    def __init__(self, clk_in, params: PLLParams, domain="sync"):
        if not isinstance(params, PLLParams):
            raise TypeError(f"PLL parameters must be a PLLParams, not {params!r}")
        if not (isinstance(domain, str) and domain):
            raise TypeError(f"PLL domain must be a domain name, not {domain!r}")
        outs = params.outputs
        if not isinstance(outs, tuple) or not all(isinstance(o, PLLOutput) for o in outs):
            raise TypeError(f"PLL parameters' outputs must be a tuple of PLLOutput, not {outs!r}")
        if len(outs) > len(SECONDARY_PORTS) or [o.port for o in outs] != list(SECONDARY_PORTS[:len(outs)]):
            raise ValueError(f"PLL outputs must use {', '.join(SECONDARY_PORTS)} in that order, not "
                             f"{', '.join(o.port for o in outs)}")
        names = [domain] + [o.domain for o in outs]
        if len(set(names)) != len(names):
            raise ValueError(f"PLL domains must differ: {', '.join(names)}")
        for o in outs:
            if not 1 <= o.div <= DIV_MAX:
                raise ValueError(f"PLL output {o.domain!r}: {o.port}_DIV must be in [1, {DIV_MAX}], "
                                 f"not {o.div!r}")
            if not 0 <= o.cphase <= CPHASE_MAX:
                raise ValueError(f"PLL output {o.domain!r}: {o.port}_CPHASE must be in [0, {CPHASE_MAX}], "
                                 f"not {o.cphase!r}")
            if not 0 <= o.fphase <= 7:
                raise ValueError(f"PLL output {o.domain!r}: {o.port}_FPHASE must be in [0, 7], "
                                 f"not {o.fphase!r}")
        self.clk_in = clk_in
        self.params = params
        self.domain = domain
        self.locked = Signal()

    def elaborate(self, platform):
        m = Module()
        p = self.params
        cd = ClockDomain(self.domain)
        m.domains += cd
        clkop = Signal()
        kw = {}
        clocks = [(self.domain, clkop, p.f_out_mhz)]
        for o in p.outputs:
            clk = Signal(name=f"clk_{o.domain}")
            kw.update({f"a_FREQUENCY_PIN_{o.port}": f"{o.f_out_mhz:g}",
                       f"p_{o.port}_ENABLE": "ENABLED", f"p_{o.port}_DIV": o.div,
                       f"p_{o.port}_CPHASE": o.cphase, f"p_{o.port}_FPHASE": o.fphase,
                       f"o_{o.port}": clk})
            clocks.append((o.domain, clk, o.f_out_mhz))
        m.submodules.pll = Instance(
            "EHXPLLL",
            a_FREQUENCY_PIN_CLKI=f"{p.f_in_mhz:g}",
            a_FREQUENCY_PIN_CLKOP=f"{p.f_out_mhz:g}",
            a_ICP_CURRENT="12",
            a_LPF_RESISTOR="8",
            a_MFG_ENABLE_FILTEROPAMP="1",
            a_MFG_GMCREF_SEL="2",
            p_PLLRST_ENA="DISABLED",
            p_INTFB_WAKE="DISABLED",
            p_STDBY_ENABLE="DISABLED",
            p_DPHASE_SOURCE="DISABLED",
            p_OUTDIVIDER_MUXA="DIVA",
            p_OUTDIVIDER_MUXB="DIVB",
            p_OUTDIVIDER_MUXC="DIVC",
            p_OUTDIVIDER_MUXD="DIVD",
            p_CLKI_DIV=p.refclk_div,
            p_CLKOP_ENABLE="ENABLED",
            p_CLKOP_DIV=p.output_div,
            p_CLKOP_CPHASE=p.output_div - 1,
            p_CLKOP_FPHASE=0,
            p_FEEDBK_PATH="CLKOP",
            p_CLKFB_DIV=p.feedback_div,
            i_RST=0,
            i_STDBY=0,
            i_CLKI=self.clk_in,
            i_CLKFB=clkop,
            i_PHASESEL0=0, i_PHASESEL1=0, i_PHASEDIR=1, i_PHASESTEP=1,
            i_PHASELOADREG=1, i_PLLWAKESYNC=0, i_ENCLKOP=0,
            o_CLKOP=clkop,
            o_LOCK=self.locked,
            **kw,
        )
        m.d.comb += cd.clk.eq(clkop)
        # The main domain's reset reaches every reset flip-flop of the design
        # (15,640 loads at 64 channels): on fabric routing that net was
        # 19 ns to its farthest load. A DCCA puts it on a global network, as
        # the clock is; nextpnr promotes only clocks by itself.
        rst = Signal(name=f"{self.domain}_rst_local")
        m.submodules.rst_sync = AsyncFFSynchronizer(~self.locked, rst, o_domain=self.domain,
                                                    async_edge="pos")
        m.submodules.rst_global = Instance("DCCA", i_CLKI=rst, i_CE=1, o_CLKO=cd.rst)
        for o, (_, clk, _) in zip(p.outputs, clocks[1:]):
            ocd = ClockDomain(o.domain)
            m.domains += ocd
            m.d.comb += ocd.clk.eq(clk)
            m.submodules[f"rst_sync_{o.domain}"] = ResetSynchronizer(~self.locked, domain=o.domain)
        if platform is not None:
            for _, clk, f in clocks:
                platform.add_clock_constraint(clk, f * 1e6)
        return m
