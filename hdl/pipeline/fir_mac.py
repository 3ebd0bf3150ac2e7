"""The FIR interpolator's first stage: one serial multiplier-accumulator per
pipeline, computing each slot's intermediate values U[J..J+2]."""

from amaranth.hdl import Module, Signal, Mux, Cat, signed
from amaranth.lib import wiring, data
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from rast.model.contract.fixedpoint import (STREAM_WIDTH, FIR_PHASE_BITS, FIR_TAPS, FIR_COEF_WIDTH,
                                            FIR_COEF_FRAC, FIR_ACC_WIDTH, MAC_RESULT_CYCLES,
                                            fir_coefficients, mac_merge_cycles)
from ..ecp5_primitives import RegisteredMultiplier, kept_register
from ..iq import IQ
from ..register_chain import delayed, ring_delay, cleared, select_registered

__all__ = ["FirMac", "COEF_ROM_SPLIT_BITS", "ACC_LOW_BITS"]

#: Address bits of the FIR coefficient ROM's second level (2**k first-level
#: ROMs): 16 ROMs of 32 entries, a 5-input function per bit (one LUT and the
#: slice's multiplexer). Eight of 64 entries were synthesised as three LUTs
#: in series, the latest path of a 16-channel build (6.1 ns).
COEF_ROM_SPLIT_BITS = 4

#: Bits of the FIR accumulator's lower half (its sum a clock before the upper's).
ACC_LOW_BITS = 19


class FirMac(wiring.Component):
    """The FIR's multiplier-accumulator: a visiting slot with a job in issue
    reads its tap's word (the word cache's) and coefficient (a ROM in
    logic), both through registered addresses; the product (again in fabric)
    is accumulated in a ring of M accumulators (one per slot), rounded and
    saturated at the job's last tap, and put into the slot's state
    :attr:`latency` (``mac_merge_cycles``) clocks after the visit.

    Members
    -------
    tap, cphase, issuing, tap_last, dest : In
        The visiting slot's job: the tap, the phase, whether a tap is issued,
        whether it is the last, which U value the job makes.
    word : In(IQ(16))
        The tap's cache word, WORD_LATENCY clocks after the visit.
    put : Out(3), val : Out(IQ(16))
        A job's U value (``put`` one-hot: U[J], U[J+1] or U[J+2]) for the slot
        whose state update takes it, ``latency`` clocks after its last tap's visit.
    """

    #: Clocks from the visit to ``word`` (the cache's registered address, then
    #: its banks selected in registered levels beside the ROM's).
    WORD_LATENCY = 4

    def __init__(self, slots):
        self._slots = slots
        super().__init__({"tap": In(range(FIR_TAPS)), "cphase": In(FIR_PHASE_BITS), "issuing": In(1),
                          "tap_last": In(1), "dest": In(range(3)), "word": In(IQ(STREAM_WIDTH)),
                          "put": Out(3), "val": Out(IQ(STREAM_WIDTH))})

    @property
    def latency(self) -> int:
        """Clocks from a tap's visit to its U value at the slot's state update."""
        return mac_merge_cycles(self._slots)

    def elaborate(self, platform):
        m = Module()
        M = self._slots
        T, PB, W = FIR_TAPS, FIR_PHASE_BITS, STREAM_WIDTH
        TB = (T - 1).bit_length()
        coefs = fir_coefficients()
        rom_init = [0] * ((1 << PB) << TB)
        for p, row in enumerate(coefs):
            for k, v in enumerate(row):
                rom_init[(p << TB) | k] = v
        # In logic, not a block RAM (the block RAMs are the pool's and the
        # delays'), and in three registered levels: ROMs of the address's low
        # bits (a 5-input function per bit), then a multiplexer of their
        # outputs by the high bits in two (``select_registered``). The whole
        # 9-input ROM in one clock was the pipeline's worst path (7.9 ns);
        # 7-input ROMs, four LUTs in series, were still among the 200 MHz
        # build's late endpoints (6.9 ns).
        addr_bits = TB + PB
        low_bits = addr_bits - COEF_ROM_SPLIT_BITS
        full = Cat(self.tap, self.cphase)
        rom_high = delayed(m, full[low_bits:], 2, "mac_rom_high", data=True)   # beside the ROMs' words
        parts = []
        for k in range(1 << COEF_ROM_SPLIT_BITS):
            rom = Memory(shape=signed(FIR_COEF_WIDTH), depth=1 << low_bits,
                         init=rom_init[k << low_bits:(k + 1) << low_bits], attrs={"rom_style": "logic"})
            m.submodules[f"coef_rom{k}"] = rom
            rd = rom.read_port(domain="comb")
            part = Signal(signed(FIR_COEF_WIDTH), name=f"mac_coef{k}", reset_less=True)
            # Each ROM its own address register, 0 where the high bits do not
            # select it (its word is not taken then): copies that differ, so
            # synthesis keeps them apart. One register for the four ROMs was
            # n10_20_200's worst path (its fan-out, 6.9 ns).
            rom_addr = Signal(low_bits, name=f"mac_rom_addr{k}", reset_less=True)
            m.d.sync += rom_addr.eq(Mux(full[low_bits:] == k, full[:low_bits], 0))
            m.d.comb += rd.addr.eq(rom_addr)
            m.d.sync += part.eq(rd.data)
            parts.append(part)
        # the ROMs' words selected in two registered levels, then the
        # coefficient in a register for each multiplier (kept)
        coef = select_registered(m, parts, rom_high, "mac_coef_sel")
        word = self.word                          # beside the ROM's three levels
        flags = data.StructLayout({"valid": 1, "first": 1, "last": 1, "dest": range(3)})
        f0 = Signal(flags, name="mac_f0")
        m.d.comb += [f0.valid.eq(self.issuing), f0.first.eq(self.tap == 0), f0.last.eq(self.tap_last),
                     f0.dest.eq(self.dest)]
        fmul = delayed(m, f0, 7, "mac_f")                     # with the multiplier's output, again
        fprod = delayed(m, fmul, 1, "mac_fp")                 # with the product in fabric
        fhigh = delayed(m, fprod, 1, "mac_fh")               # with the upper half's sum
        # with the result: the U value a finished job writes, one-hot, from
        # registers (a job's last tap's destination decoded into stage B's
        # merge was late at 16 channels)
        put0 = Signal(3, name="mac_put0")
        m.d.sync += put0.eq(Cat(*[fhigh.valid & fhigh.last & (fhigh.dest == k) for k in range(3)]))
        res = Signal(IQ(W), name="mac_res", reset_less=True)
        for part in ("re", "im"):
            mul = RegisteredMultiplier(W, FIR_COEF_WIDTH, input_reg=True)
            m.submodules[f"fir_mul_{part}"] = mul
            m.d.comb += [mul.en.eq(1), mul.a.eq(getattr(word, part)),
                         mul.b.eq(kept_register(m, platform, coef, f"mac_coef_{part}").as_signed())]
            # The multiplier's output in a register beside it, then the
            # product, 0 where no tap is issued (its register's reset), beside
            # the accumulator. The multiplier's output straight into that
            # register was the 16-channel build's worst path: one route of
            # 5.1 ns from a multiplier placed 74 tiles away.
            mul_out = delayed(m, mul.o, 1, f"fir_mul_out_{part}", data=True)
            prod = Signal(signed(FIR_ACC_WIDTH), name=f"fir_prod_{part}", reset_less=True)
            m.d.sync += prod.eq(cleared(mul_out, ~fmul.valid))
            # One accumulator per slot: this slot's, updated, then round the
            # ring (M clocks) back to its next tap. In two halves, the upper a
            # clock after the lower with its carry (the 38-bit sum in one clock
            # was a latest path of a two-pipeline build, 6.1 ns); each half
            # goes round a ring of its own. Each half is the sum of the
            # previous value, 0 at a job's first tap (the ring's output
            # cleared), and the product, 0 without a tap: an adder straight
            # into the register (a multiplexer after the adder was in the
            # 64-channel build's late paths, 5.7 ns).
            acc_lo = Signal(ACC_LOW_BITS, name=f"fir_acc_lo_{part}", reset_less=True)
            acc_hi = Signal(FIR_ACC_WIDTH - ACC_LOW_BITS, name=f"fir_acc_hi_{part}", reset_less=True)
            if M > 1:
                prev_lo, _ = ring_delay(m, acc_lo, M - 1, [0] * (M - 1), f"fir_accs_lo_{part}",
                                         clear=fmul.valid & fmul.first, platform=platform)
                prev_hi, _ = ring_delay(m, acc_hi, M - 1, [0] * (M - 1), f"fir_accs_hi_{part}",
                                         clear=fprod.valid & fprod.first, platform=platform)
            else:
                prev_lo = cleared(acc_lo, fprod.valid & fprod.first)
                prev_hi = cleared(acc_hi, fhigh.valid & fhigh.first)
            sum_lo = Signal(ACC_LOW_BITS + 1, name=f"fir_sum_lo_{part}")
            carry = Signal(name=f"fir_carry_{part}", reset_less=True)
            m.d.comb += sum_lo.eq(prev_lo + prod[:ACC_LOW_BITS])
            m.d.sync += [acc_lo.eq(sum_lo), carry.eq(sum_lo[-1])]
            prod_hi = delayed(m, prod[ACC_LOW_BITS:], 1, f"fir_prod_hi_{part}", data=True)
            m.d.sync += acc_hi.eq(prev_hi + prod_hi + carry)
            acc = Signal(signed(FIR_ACC_WIDTH), name=f"fir_acc_{part}")
            m.d.comb += acc.eq(Cat(delayed(m, acc_lo, 1, f"fir_acc_lo_{part}", data=True), acc_hi))
            rounded = Signal(signed(FIR_ACC_WIDTH - FIR_COEF_FRAC + 1), name=f"fir_rnd_{part}", reset_less=True)
            half = 1 << (FIR_COEF_FRAC - 1)
            m.d.sync += rounded.eq((acc + half) >> FIR_COEF_FRAC)
            lo, hi = -(1 << (W - 1)), (1 << (W - 1)) - 1
            # rounded > hi and rounded < lo, decided on the accumulator beside
            # the rounding (floor((a + half) / 2**F) > hi <=> a >= (hi + 1) * 2**F
            # - half, < lo <=> a < lo * 2**F - half): the compares after the
            # rounding, then the clip, were 7.5 ns in a two-pipeline build).
            # Each compare in two parts: the lower half's a clock earlier,
            # beside it, then 2 a_hi + (a_lo >= k_lo) >= 2 k_hi + 1, which is
            # a >= k, on the upper half's width (the whole accumulator's
            # compare was among a 16-channel build's late paths, 4.8-4.9 ns).
            over = Signal(name=f"fir_over_{part}", reset_less=True)
            under = Signal(name=f"fir_under_{part}", reset_less=True)
            for flag, bound, below in ((over, ((hi + 1) << FIR_COEF_FRAC) - half, False),
                                       (under, (lo << FIR_COEF_FRAC) - half, True)):
                lo_ge = Signal(name=f"{flag.name}_lo", reset_less=True)
                m.d.sync += lo_ge.eq(acc_lo >= (bound & ((1 << ACC_LOW_BITS) - 1)))
                ge = Cat(lo_ge, acc_hi).as_signed() >= 2 * (bound >> ACC_LOW_BITS) + 1
                m.d.sync += flag.eq(~ge if below else ge)
            m.d.sync += getattr(res, part).eq(Mux(over, hi, Mux(under, lo, rounded)))
        # addresses, ROM levels (the word beside), multiplier in and out, its
        # output again, product, the accumulator's two halves, round, saturate
        assert 1 + 3 + 2 + 1 + 1 + 1 + 1 + 1 + 1 == MAC_RESULT_CYCLES
        pad = mac_merge_cycles(M) - MAC_RESULT_CYCLES
        res_d = delayed(m, res, pad, "mac_res", data=True)
        m.d.comb += [self.put.eq(delayed(m, put0, 2 + pad, "mac_put")), self.val.eq(res_d)]
        return m
