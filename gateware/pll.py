"""ECP5 clocking: an ``EHXPLLL`` making the RTS sample clock from the board clock.

:func:`pll_params` searches the divider settings the way ``ecppll`` does
(reference divider, feedback divider, output divider; the PLL's frequency
limits from the ECP5 data sheet, as ecppll uses them) and :class:`ECP5PLL`
instantiates the primitive with the feedback taken from ``CLKOP``.
"""

from dataclasses import dataclass

from amaranth.hdl import Elaboratable, Module, Signal, ClockDomain, ClockSignal, Instance
from amaranth.lib.cdc import ResetSynchronizer

__all__ = ["PLLParams", "pll_params", "ECP5PLL"]

# ECP5 EHXPLLL limits (ecppll, FPGA-DS-02012): MHz.
PFD_MIN, PFD_MAX = 3.125, 400.0
VCO_MIN, VCO_MAX = 400.0, 800.0
OUT_MIN, OUT_MAX = 3.125, 400.0


@dataclass(frozen=True)
class PLLParams:
    f_in_mhz: float
    f_out_mhz: float         # achieved
    refclk_div: int          # CLKI_DIV
    feedback_div: int        # CLKFB_DIV
    output_div: int          # CLKOP_DIV

    @property
    def f_vco_mhz(self) -> float:
        return self.f_out_mhz * self.output_div

    @property
    def f_pfd_mhz(self) -> float:
        return self.f_in_mhz / self.refclk_div


def pll_params(f_in_mhz: float, f_out_mhz: float, tolerance_mhz: float = 0.01) -> PLLParams:
    """Divider settings giving ``f_out_mhz`` from ``f_in_mhz`` (feedback from CLKOP).

    ``f_out = f_in * feedback_div / refclk_div``, ``f_vco = f_out * output_div``.
    Among the settings closest to the request, the one with the VCO nearest
    600 MHz is taken (ecppll's choice). Raises ``ValueError`` when nothing is
    within ``tolerance_mhz``.
    """
    for name, v in (("Input frequency", f_in_mhz), ("Output frequency", f_out_mhz)):
        if not isinstance(v, (int, float)) or isinstance(v, bool) or v <= 0:
            raise TypeError(f"{name} must be a positive number of MHz, not {v!r}")
    if not OUT_MIN <= f_out_mhz <= OUT_MAX:
        raise ValueError(f"PLL output frequency must be in [{OUT_MIN}, {OUT_MAX}] MHz, not {f_out_mhz!r}")
    best = None
    for ref in range(1, 129):
        pfd = f_in_mhz / ref
        if not PFD_MIN <= pfd <= PFD_MAX:
            continue
        for fb in range(1, 81):
            out = pfd * fb
            if not OUT_MIN <= out <= OUT_MAX:
                continue
            for od in range(1, 129):
                vco = out * od
                if not VCO_MIN <= vco <= VCO_MAX:
                    continue
                key = (round(abs(out - f_out_mhz), 9), abs(vco - 600.0))
                if best is None or key < best[0]:
                    best = (key, PLLParams(f_in_mhz, out, ref, fb, od))
    if best is None or best[0][0] > tolerance_mhz:
        got = "nothing" if best is None else f"{best[1].f_out_mhz:.4f} MHz"
        raise ValueError(f"The ECP5 PLL cannot make {f_out_mhz} MHz from {f_in_mhz} MHz "
                         f"(closest: {got})")
    return best[1]


class ECP5PLL(Elaboratable):
    """Clock domain ``domain`` from an ``EHXPLLL``; held in reset until locked.

    Parameters
    ----------
    clk_in : Signal
        The board clock (after its input buffer).
    params : PLLParams
    domain : str
        Name of the clock domain created.

    Members
    -------
    locked : Signal
        The PLL's ``LOCK`` output.
    """

    def __init__(self, clk_in, params: PLLParams, domain="sync"):
        if not isinstance(params, PLLParams):
            raise TypeError(f"PLL parameters must be a PLLParams, not {params!r}")
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
        )
        m.d.comb += cd.clk.eq(clkop)
        m.submodules.rst_sync = ResetSynchronizer(~self.locked, domain=self.domain)
        if platform is not None:
            platform.add_clock_constraint(clkop, p.f_out_mhz * 1e6)
        return m
