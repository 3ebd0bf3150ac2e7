"""The fixed-point contract of the replay block, written down once.

Every width, rounding step and saturation of the data path is defined here and
read from here by three users: the stream quantiser (``rast.model.physics.stream``),
the bit-exact datapath model and the Amaranth gateware (``rast.hdl``).

Formats are two's complement integers with an implied binary point:

* input sample ``x``      : signed ``INPUT_WIDTH`` bits per I and Q, full scale 1.0
* stream word ``m``       : signed ``STREAM_WIDTH`` bits per I and Q, full scale 1.0;
  packed into one ``2*STREAM_WIDTH``-bit word with I in the low half
* channel gain ``g``      : unsigned ``GAIN_WIDTH`` bits, ``GAIN_FRAC`` of them
  fractional (``g = word / 2**GAIN_FRAC``)
* output sample ``y``     : signed ``OUTPUT_WIDTH`` bits per I and Q, same scale as ``x``
"""

from dataclasses import dataclass

__all__ = ["Format", "INPUT", "STREAM", "GAIN", "OUTPUT", "GAIN_FRAC",
           "INPUT_WIDTH", "STREAM_WIDTH", "GAIN_WIDTH", "OUTPUT_WIDTH",
           "PHASE_FRAC_BITS", "pack_iq", "unpack_iq"]


@dataclass(frozen=True)
class Format:
    """An integer format: ``width`` bits, ``frac`` of them after the binary point."""
    width: int
    frac: int
    signed: bool

    @property
    def min(self) -> int:
        return -(1 << (self.width - 1)) if self.signed else 0

    @property
    def max(self) -> int:
        return (1 << (self.width - 1)) - 1 if self.signed else (1 << self.width) - 1


INPUT_WIDTH = 16
STREAM_WIDTH = 16
GAIN_WIDTH = 17
GAIN_FRAC = 16
OUTPUT_WIDTH = 16

#: Fractional bits of the stream-rate phase accumulator (the increment per RTS
#: sample is ``round(stream_rate / sample_rate * 2**PHASE_FRAC_BITS)``).
PHASE_FRAC_BITS = 32

INPUT = Format(INPUT_WIDTH, INPUT_WIDTH - 1, signed=True)
STREAM = Format(STREAM_WIDTH, STREAM_WIDTH - 1, signed=True)
GAIN = Format(GAIN_WIDTH, GAIN_FRAC, signed=False)
OUTPUT = Format(OUTPUT_WIDTH, INPUT_WIDTH - 1, signed=True)


def pack_iq(i, q, width=STREAM_WIDTH):
    """Pack signed I and Q integers (numpy arrays) into unsigned words, I low."""
    import numpy as np
    mask = (1 << width) - 1
    i = np.asarray(i, dtype=np.int64)
    q = np.asarray(q, dtype=np.int64)
    return ((q & mask) << width) | (i & mask)


def unpack_iq(words, width=STREAM_WIDTH):
    """Inverse of :func:`pack_iq`: unsigned words to signed (I, Q) int64 arrays."""
    import numpy as np
    words = np.asarray(words, dtype=np.int64)
    mask = (1 << width) - 1
    half = 1 << (width - 1)
    i = ((words & mask) ^ half) - half
    q = (((words >> width) & mask) ^ half) - half
    return i, q


# ---------------------------------------------------------------------------
# The replay data path: rounding, guard bits, saturation and latency.
#
# Per channel l, with x the (delayed) input, m the stream word and g the gain
# word (all integers):
#
#   full   = x * m                       exact complex product, 33 bits per part
#   p      = round_half_up(full, 15)     PRODUCT_WIDTH (18) bits, scale of x
#   q      = round_half_up(p * g, 16)    SCALED_WIDTH (19) bits, scale of x
#   s      = sum over channels of q      SCALED_WIDTH + guard_bits(N) bits, exact
#   y      = saturate(s, OUTPUT_WIDTH)   sticky overflow flag if I or Q clipped
#
# round_half_up(v, s) = (v + 2**(s-1)) >> s  (arithmetic shift; ties go up,
# towards +inf). Every product fits one ECP5 MULT18X18D: 16x16 (or 17x16 in
# the 3-multiplier form) for the complex product, 18x17 for the gain.
# ---------------------------------------------------------------------------

import math as _math

__all__ += ["COMMON_LAG", "WINDOW_LAG", "BLOCK_LATENCY", "ACCEPT_LAG", "visit_cycles", "WORD_CYCLES",
            "CMULT_CYCLES", "GAIN_CYCLES", "MAC_RESULT_CYCLES", "POOL_FETCH_CYCLES", "REGISTER_STAGING",
            "WRITE_STAGING", "TAKE_SPACING", "take_interval", "reset_slot",
            "tree_levels", "TREE_LEVEL_CYCLES", "tree_cycles", "tree_operand_registers", "mac_merge_cycles", "mac_visits", "engine_output_cycles", "board_latency"]
__all__ += ["PRODUCT_SHIFT", "PRODUCT_WIDTH", "GAIN_SHIFT", "SCALED_WIDTH",
            "INTERP_FRAC_BITS", "INTERPOLATIONS", "FIR_PHASE_BITS", "FIR_PHASES", "FIR_TAPS",
            "FIR_LEAD", "FIR_KAISER_BETA", "FIR_CUTOFF", "FIR_COEF_WIDTH", "FIR_COEF_FRAC", "FIR_ACC_WIDTH", "FIR_MAX_INCREMENT",
            "FIR_MIN_LENGTH", "FIR_REFILL_SAMPLES", "CACHE_WORDS", "CACHE_GUARD_WORDS", "CACHE_FILL_WORDS",
            "POOL_BANK_WORDS", "POOL_BACKENDS", "SDRAM_CLOCK_HZ", "SDRAM_FABRIC_HZ", "SDRAM_MAX_POOL_WORDS",
            "SDRAM_QUEUE_DEPTH", "SDRAM_REQUEST_FIFO", "SDRAM_WORD_CLOCKS", "SDRAM_REFRESH_CLOCKS",
            "SDRAM_REFRESH_INTERVAL_CLOCKS", "SDRAM_PATH_CLOCKS", "sdram_fetch_clocks", "cache_need_words", "fetch_wait_samples", "pool_words_for", "FIR_MIN_SAMPLES_PER_STEP", "fir_prototype",
            "fir_coefficients", "refill_samples", "max_phase_increment", "min_stream_length",
            "CMULT_FORMS", "guard_bits", "sum_width", "round_half_up", "saturate",
            "delay_depth", "ReplayContract",
            "DDR_INPUT_LATENCY", "DDR_OUTPUT_LATENCY", "PIN_LAG", "board_input_latency", "rate_mismatch",
            "board_output_latency", "TARGETS", "path_latency"]

#: The complex product is rounded by this many bits: Q15 x Q15 -> Q15.
PRODUCT_SHIFT = STREAM_WIDTH - 1
#: Width of the rounded complex product: |x*m| <= 2 (full scale), plus sign.
PRODUCT_WIDTH = INPUT_WIDTH + STREAM_WIDTH + 1 - PRODUCT_SHIFT   # 18
#: The gain product is rounded by this many bits.
GAIN_SHIFT = GAIN_FRAC
#: Width of one channel's scaled product: |p| <= 2**16, g < 2 -> |q| <= 2**17.
SCALED_WIDTH = PRODUCT_WIDTH + (GAIN_WIDTH - GAIN_FRAC)             # 19
#: Fractional phase bits used by the linear interpolator (top bits of the phase).
INTERP_FRAC_BITS = 16

# ---------------------------------------------------------------------------
# Stream interpolation (``interpolation`` of the contract):
#
# * ``"hold"``: the word at the phase index, held (exact only when the stream
#   runs at one word per sample, the seed's mode);
# * ``"linear"``: ``s0 + round_half_up((s1 - s0)*f, 16)`` between adjacent words;
# * ``"fir"`` (default): two stages. A polyphase FIR (FIR_PHASES phases of
#   FIR_TAPS taps, a Kaiser-windowed sinc) makes the intermediate sequence
#   U[J] at FIR_PHASES x the stream rate, J = index*FIR_PHASES + top
#   FIR_PHASE_BITS of the fraction:
#
#     U[J] = sat16(round_half_up(sum_k c[p][k] * m[(w + FIR_LEAD - k) mod L], FIR_COEF_FRAC))
#
#   (w = J >> FIR_PHASE_BITS, p = J mod FIR_PHASES), then the word at the
#   multiplier is the linear step ``U[J] + round_half_up((U[J+1] - U[J])*f, 16)``
#   with f the next 16 fraction bits (U wraps at FIR_PHASES*L). U is computed
#   by one serial multiplier-accumulator per pipeline, one tap per visit of a
#   channel's slot (once per sample), only when J advances; the increment is
#   limited so that J advances at most once per FIR_MIN_SAMPLES_PER_STEP
#   samples, which leaves the MAC time to finish (``mac_visits`` below).
#   After every stream switch (and reset) the channel is muted, its phase
#   held at 0, while its word cache is filled from the pool (see the pool
#   section below) and then for FIR_REFILL_SAMPLES samples while U[0..2] are
#   computed.
# ---------------------------------------------------------------------------

INTERPOLATIONS = ("hold", "linear", "fir")
FIR_PHASE_BITS = 5
FIR_PHASES = 1 << FIR_PHASE_BITS
FIR_TAPS = 10
#: Tap k reads word ``w + FIR_LEAD - k``: the kernel spans words w-4 .. w+5.
FIR_LEAD = 5
FIR_KAISER_BETA = 8.0
#: Cut-off of the kernel as a fraction of half the stream rate (below 1 buys
#: stopband at 3/4 of the stream rate, where the first images of a 4x stream lie).
FIR_CUTOFF = 0.95
FIR_COEF_WIDTH = 18
FIR_COEF_FRAC = 16
#: Accumulator of one U value: 16 x 18 bit products, FIR_TAPS of them.
FIR_ACC_WIDTH = STREAM_WIDTH + FIR_COEF_WIDTH + (FIR_TAPS - 1).bit_length()
#: Samples between two advances of J, at least: the serial MAC needs
#: ``mac_visits(slots)`` (at most 23, at M = 1) from an advance to the next U value in
#: the channel's state.
FIR_MIN_SAMPLES_PER_STEP = 24
#: Largest PHASE_INC of a FIR build (5592405: stream rate <= sample rate / 768).
FIR_MAX_INCREMENT = (1 << (PHASE_FRAC_BITS - FIR_PHASE_BITS)) // FIR_MIN_SAMPLES_PER_STEP
#: Shortest LENGTH of a FIR build (the kernel's start address needs one wrap at most).
FIR_MIN_LENGTH = 8
#: Samples a channel stays muted (phase held at 0) after its cache is filled,
#: while the FIR computes U[0..2].
FIR_REFILL_SAMPLES = 48

# ---------------------------------------------------------------------------
# The stream pool: one memory of ``pool_words`` 32-bit words for every
# channel's stream (per channel: BASE, LENGTH, PHASE_INC). Word ``i`` of a
# channel's stream is pool word ``(BASE + i) mod 2**pool_address_width``; an
# address at or beyond ``pool_words`` reads 0.
#
# Channels do not read the pool per sample. Each keeps a cache of CACHE_WORDS
# words, the next words of its stream in order (wrapping at LENGTH), filled by
# a fetcher: a scan offers, in each sample period, every slot of one
# pipeline a fetch (pipelines in turn, so each channel once per
# ``pipelines`` periods) and a channel with room reads its next word from the
# pool (at most POOL_FETCH_CYCLES fabric clocks to the cache). The consumer
# (the hold/linear read or the FIR's multiplier-accumulator) reads only the
# cache. So the pool's read bandwidth is the sum of the stream rates, and a
# second back end (external SDRAM) can serve the same requests.
#
# Room: a channel's cache holds CACHE_FILL_WORDS words from its consumer's
# oldest needed word on; CACHE_GUARD_WORDS behind that are kept too. Needed
# at once: 1 word (hold), 2 (linear), FIR_TAPS (fir).
#
# After a switch (and reset) the cache is refilled from the new stream while
# the channel is muted with its phase at 0: ``fetch_wait_samples`` samples
# (the visit after the switch restarts the fetcher; each of the
# CACHE_FILL_WORDS words then waits at most one scan of ``pipelines``
# periods; one period per sample is the slowest case), then
# FIR_REFILL_SAMPLES more for the FIR. Between switches a channel consumes at
# most one word per ``pipelines`` samples (the increment is limited
# accordingly), no faster than the scan refills, so the words fetched ahead
# stay ahead.
# ---------------------------------------------------------------------------

#: Words of each channel's cache (a power of two: positions wrap naturally).
CACHE_WORDS = 16
#: Cache words kept behind the oldest needed one.
CACHE_GUARD_WORDS = 3
#: Words a channel fetches ahead of its consumer: all the room there is. A
#: switch waits until this many have arrived, so that the consumer starts with
#: every word it may need while the next ones are fetched.
CACHE_FILL_WORDS = CACHE_WORDS - CACHE_GUARD_WORDS
#: Fabric clocks from the scan granting a fetch to the word readable in the
#: cache, at most (the gateware checks its own path against it:
#: ``rast.hdl.replay_top``).
POOL_FETCH_CYCLES = 20
#: Words of one pool bank (on ECP5: 32 DP16KD of 16384 x 1; deeper pools are
#: banks behind a registered multiplexer).
POOL_BANK_WORDS = 16384

# ---------------------------------------------------------------------------
# The pool's SDRAM back end (``pool="sdram"``: rast.hdl.sdram_pool on
# LiteDRAM, docs/sdram.md). The streams live in the ULX3S's SDRAM; fetches
# reach it through a request FIFO of SDRAM_REQUEST_FIFO entries (a scan
# grants a fetch only while that FIFO has room for every grant already on
# its way) and come back in the order asked, after a latency that varies
# with refresh, the other channels' fetches and the host's writes. The
# contract takes the worst case, derived in docs/sdram.md ("Worst-case fetch
# latency") from the controller's timings:
#
#   a word costs at most SDRAM_WORD_CLOCKS controller clocks (a row miss,
#   two 16-bit column commands, a read/write turnaround), twice that while
#   the host writes (the pool gives the host every other turn);
#   a refresh at most SDRAM_REFRESH_CLOCKS, one every
#   SDRAM_REFRESH_INTERVAL_CLOCKS;
#   a fetch waits behind at most the request FIFO, the pool's reads
#   outstanding and its host writes (SDRAM_REQUEST_FIFO + 3 x
#   SDRAM_QUEUE_DEPTH words), plus SDRAM_PATH_CLOCKS of crossings and read path.
#
# In fabric clocks these scale by fabric clock / SDRAM_CLOCK_HZ (the fabric
# clock is ``slots x sample_rate_hz``; SDRAM_FABRIC_HZ, the fastest the
# engine is built for, when the rate is not stated). From them:
#
#   refill after a switch: the latency bound, plus every channel's cache
#   fill queued before this one (N x (CACHE_FILL_WORDS + 1) words at the
#   write-interleaved word cost);
#   the highest stream rate, one word per ``word_samples`` samples: the
#   bandwidth (N channels' words at the write-interleaved cost) and the
#   latency (a word fetched when the consumer releases one is needed
#   CACHE_FILL_WORDS - need - 1 releases later, at the latest).
# ---------------------------------------------------------------------------

POOL_BACKENDS = ("bram", "sdram")
#: LiteDRAM controller clock (litex-boards' ULX3S target).
SDRAM_CLOCK_HZ = 50_000_000
#: Fabric clock assumed for the SDRAM bounds when no sample rate is stated.
SDRAM_FABRIC_HZ = 200_000_000
#: Stream words the ULX3S's 32 MB SDRAM holds (a 23-bit word address).
SDRAM_MAX_POOL_WORDS = 1 << 23
#: Reads the SDRAM pool keeps outstanding (``SDRAMStreamPool(queue_depth=)``).
SDRAM_QUEUE_DEPTH = 16
#: Entries of the engine's request FIFO in front of the SDRAM pool.
SDRAM_REQUEST_FIFO = 16
#: Controller clocks a word costs at most; a refresh; the refresh interval;
#: crossings and read path (docs/sdram.md).
SDRAM_WORD_CLOCKS = 10
SDRAM_REFRESH_CLOCKS = 10
SDRAM_REFRESH_INTERVAL_CLOCKS = 391
SDRAM_PATH_CLOCKS = 12


def sdram_fetch_clocks() -> int:
    """Controller clocks from a fetch entering the engine's request FIFO to its
    answer leaving the pool, at most (with refreshes in that window)."""
    ahead = SDRAM_REQUEST_FIFO + 3 * SDRAM_QUEUE_DEPTH + 1
    t = SDRAM_PATH_CLOCKS + ahead * SDRAM_WORD_CLOCKS
    while True:
        refreshes = -(-t // SDRAM_REFRESH_INTERVAL_CLOCKS) + 1
        t_next = SDRAM_PATH_CLOCKS + ahead * SDRAM_WORD_CLOCKS + refreshes * SDRAM_REFRESH_CLOCKS
        if t_next == t:
            return t
        t = t_next


def fir_prototype() -> "np.ndarray":
    """The FIR's prototype at FIR_PHASES x the stream rate, offsets
    ``-(FIR_PHASES*FIR_LEAD - 1) .. FIR_PHASES*FIR_LEAD - 1``: a low-pass
    ``a*sinc(a*d/FIR_PHASES)`` (a = FIR_CUTOFF, cut-off a/2 of the stream
    rate, gain 1 per phase) times a Kaiser window (beta FIR_KAISER_BETA)."""
    import numpy as np
    half = FIR_PHASES * FIR_LEAD - 1
    d = np.arange(-half, half + 1)
    a = FIR_CUTOFF
    return a * np.sinc(a * d / FIR_PHASES) * np.kaiser(2 * half + 1, FIR_KAISER_BETA)


def fir_coefficients() -> tuple[tuple[int, ...], ...]:
    """``c[p][k]`` (FIR_PHASES x FIR_TAPS signed FIR_COEF_WIDTH-bit integers,
    FIR_COEF_FRAC fractional bits): the prototype at offset
    ``p + FIR_PHASES*(k - FIR_LEAD)`` (0 outside it), each phase scaled to
    unit sum and rounded to nearest, the rounding residual added to its
    largest tap, so that every phase sums to exactly ``2**FIR_COEF_FRAC``:
    constant words pass unchanged, and the phases' DC gains cannot differ
    (a difference would modulate at the intermediate rate: an image)."""
    import numpy as np
    g = fir_prototype()
    half = (len(g) - 1) // 2
    table = []
    for p in range(FIR_PHASES):
        d = p + FIR_PHASES * (np.arange(FIR_TAPS) - FIR_LEAD)
        v = np.where(np.abs(d) <= half, g[np.clip(d + half, 0, 2 * half)], 0.0)
        row = np.round(v / v.sum() * (1 << FIR_COEF_FRAC)).astype(np.int64)
        row[np.argmax(np.abs(row))] += (1 << FIR_COEF_FRAC) - row.sum()
        table.append(tuple(int(x) for x in row))
    lim = 1 << (FIR_COEF_WIDTH - 1)
    assert all(-lim <= v < lim for row in table for v in row)
    return tuple(table)

# ---------------------------------------------------------------------------
# The time-multiplexed engine (``rast.hdl.replay_top``) and its schedule.
#
# The fabric clock runs ``slots`` = M clocks per RTS sample (M = f_clk / f_s;
# M = 1 for a wide-band radar whose sample rate is the fabric's). A
# free-running slot counter cuts time into *periods* of M clocks; period j
# starts at the clock O(j) in which the counter is 0 and accepts an input
# sample there if one is offered (else the period is a bubble: no step, no
# output). Steps are counted as in the model: step n is the n-th accepted
# input sample, and output sample n is computed from step n alone:
#
#   c[n]   = x[n - COMMON_LAG - d_c[n]]         the common delay line
#   t_l[n] = c[n - WINDOW_LAG - d_l[n]]         channel l's tap of its window
#   y[n]   = saturate(sum_l gain(cmult(t_l[n], w_l[n]), g_l[n]))
#
# (d_c, d_l, g_l, w_l as applied at step n). So the block's latency in steps
# is L = COMMON_LAG + WINDOW_LAG, whatever M and N; the fabric clocks that
# output n takes to leave the block (``engine_output_cycles``) are not seen
# in the step count, only on a board (``board_latency``).
#
# The pipelines run two clocks behind the accepting clock (ACCEPT_LAG: the
# accept strobe is registered beside the input's pins, then copied to each
# pipeline), from O'(j) = O(j) + 2.
# Channel c = p*M + s is served by pipeline p in slot s: the channel's
# registers are read (multiplexed by slot, registered) from O'(j) + s, and
# its state, kept in a ring of M positions per pipeline, is at the ring's
# head at O'(j) + s + visit_cycles(M), where it is updated (in one stage at
# M = 1, in two at M >= 2) and its word, tap, product and gain follow a
# fixed pipeline. Host writes land in the register file in the clock before
# O'(j) (they are taken from the bus REGISTER_STAGING clocks earlier,
# ``rast.hdl.registers``), so a write taken in clock t is seen by every
# channel from the first step whose input is accepted in clock
# t + WRITE_STAGING or later.
# ---------------------------------------------------------------------------

#: Common delay line: c[n] = x[n - COMMON_LAG - COMMON_DELAY].
COMMON_LAG = 1
#: Each channel's window: t_l[n] = c[n - WINDOW_LAG - DELAY[l]].
WINDOW_LAG = 1
#: The block's latency L in samples (steps): an echo of channel l appears
#: ``L + COMMON_DELAY + DELAY[l]`` samples after its input.
BLOCK_LATENCY = COMMON_LAG + WINDOW_LAG
#: Clocks from the accepting clock to the pipelines' period start O': the
#: accept strobe in a register beside the input's pins, then in each
#: pipeline's copy (from the pins' one place to a pipeline across the device
#: in one clock was the 64-channel build's latest path, 7.1 ns).
ACCEPT_LAG = 2
#: Clocks from the visit to the stream word in its register: the cache's
#: registered address (hold, linear; the FIR's U values wait beside it), the
#: operands, the difference, the multiplier's input and output registers, the
#: product in fabric, the sum.
WORD_CYCLES = 7
#: Clocks from the operands to the rounded complex product, per form: the
#: multipliers' input and output registers, the products in fabric, the
#: low and high parts' difference/sum with the rounding constant, their sum
#: (3mult: one more for the pre-additions).
CMULT_CYCLES = {"4mult": 5, "3mult": 6}
#: Clocks from the rounded product to the rounded gain product (the product
#: again in a register beside the multiplier, the multiplier's input and
#: output registers, the product in fabric, the rounding).
GAIN_CYCLES = 5
#: Clocks from the visit to the FIR MAC's rounded, saturated U value (the
#: cache's and the coefficient ROM's registered addresses, the ROM's three
#: levels with the word beside, multiplier in and out, its output again in a
#: register beside it, the product in fabric, the accumulator's lower and
#: upper halves, round, saturate).
MAC_RESULT_CYCLES = 12


def reset_slot(slots: int) -> int:
    """The top's slot counter in the clock of reset. The pipelines' period
    starts in the clock after reset and M clocks apart; the top accepts
    input when its counter is 0, ACCEPT_LAG clocks before a period start."""
    return (ACCEPT_LAG - 1) % slots


def visit_cycles(slots: int) -> int:
    """Clocks from a slot's register read to its visit: the slot multiplexer
    in one registered stage (M <= 2), or two (a 4:1 stage, then the groups)."""
    return 1 if slots <= 2 else 2


#: Clocks between a host write taken from the bus and the clock in which it
#: lands in the register file (the one before the pipelines' period start),
#: at every M: the bus first in a register of the register file's own (the
#: bridge's data register sat far from the decode and the LENGTH clamp, 7.4
#: ns of routing into the clamp in an SDRAM build; the SWAP check's hit
#: flags decoded from the bridge's address, 7.0-7.7 ns at 64 channels), the
#: SWAP check's three registered levels after it (the register file's RAM
#: words, the comparisons, their AND; a RAM's read and the comparison in one
#: clock were the 64-channel build's worst path, 9.8 ns, docs/bitstream.md),
#: and the landing.
REGISTER_STAGING = 5
#: Clocks between a host write taken from the bus and the accepting clock of
#: the first step it takes effect for (its *landing clock* as the host sees
#: it): the write lands in the register file ACCEPT_LAG - 1 clocks later. A
#: write takes effect from the first input accepted in its landing clock or
#: later.
WRITE_STAGING = REGISTER_STAGING - (ACCEPT_LAG - 1)
#: Fewest clocks between two accesses taken from the bus: a stream word's
#: CRC (a clock that loads the word, then a byte a clock) is complete before
#: the SWAP check of the next access copies it, three clocks before that
#: one lands (each group compares its copy a clock later).
TAKE_SPACING = 8


def take_interval(slots: int) -> int:
    """Clocks from one access taken from the bus to the next: whole periods
    of M clocks, at least TAKE_SPACING (so that every write lands in an
    accepting clock): M from M = 8; 8 at M = 1, 2, 4; 9 at M = 3; 2M at
    M = 5 to 7."""
    return slots * -(-TAKE_SPACING // slots)


def tree_levels(pipelines: int) -> int:
    """Levels of the adder tree over the pipelines' period sums."""
    return (pipelines - 1).bit_length()


#: Clocks per level of the adder tree: the operands again in registers beside
#: the adder, then the sum. (The sum straight from the operands' registers
#: was among the 16-channel build's late paths once its pipelines were
#: spread over the chip: 5.7 ns, the halves' sums 80 columns apart.)
TREE_LEVEL_CYCLES = 2


def tree_operand_registers(pipelines: int, level: int) -> int:
    """Registers each operand of tree level ``level`` (0 the first) passes
    on its way to the adder: TREE_LEVEL_CYCLES - 1, and from three levels
    (five pipelines or more) one more on the last level. That level adds
    the sums of the two halves of the pipelines, which sit on the two
    halves of the die (one route from the left half's operand register to
    the adder, 3.95 ns of 6.28, was the only late path of the 64-channel
    build at 160 MHz, seed 3)."""
    levels = tree_levels(pipelines)
    return TREE_LEVEL_CYCLES - 1 + (level == levels - 1 and levels >= 3)


def tree_cycles(pipelines: int) -> int:
    """Clocks of the adder tree over the pipelines: per level its operand
    registers (``tree_operand_registers``), then the sum."""
    return sum(tree_operand_registers(pipelines, k) + 1 for k in range(tree_levels(pipelines)))


def mac_merge_cycles(slots: int) -> int:
    """Clocks from a tap's visit to the clock in which its U value enters the
    channel's state: MAC_RESULT_CYCLES, rounded up to the ring's update
    stage (one stage at M = 1, the second of two at M >= 2)."""
    if slots == 1:
        return MAC_RESULT_CYCLES
    k = -(-(MAC_RESULT_CYCLES - 1) // slots)
    return 1 + k * slots


def mac_visits(slots: int) -> int:
    """Visits of a channel from a J advance to the new U value in its state:
    the job's start, FIR_TAPS taps, the last tap's merge."""
    return 1 + FIR_TAPS + -(-mac_merge_cycles(slots) // slots)


def engine_output_cycles(slots: int, pipelines: int, cmult_form: str = "4mult") -> int:
    """Clocks from the clock that accepts input n to the clock in which output
    n is in the saturation register (it enters the output FIFO at the next
    edge): the pipelines' period start, the last slot's visit, word, complex
    product, gain, slot accumulator, adder tree, saturation flags and clip."""
    return (ACCEPT_LAG + (slots - 1) + visit_cycles(slots) + WORD_CYCLES + CMULT_CYCLES[cmult_form]
            + GAIN_CYCLES + 1 + tree_cycles(pipelines) + 2)


CMULT_FORMS = ("4mult", "3mult")

# ---------------------------------------------------------------------------
# The board around the replay block (``rast.gateware.top.SampleIO``), in
# fabric clocks. Everything runs on the fabric clock; the converters' clocks
# (at the sample rate, M fabric clocks per period) and the DAC's data are
# patterns computed from the block's slot counter, registered once, and
# driven through ODDRX1F cells; the ADC's pins are taken by IDDRX1F cells on
# every fabric edge and the samples at the ADC clock's rising (I) and falling
# (Q) edge are kept. Edges are the fabric clock's rising edges.
#
# IDDRX1F (Lattice's ECP5U simulation library): the pin taken on rising edge
# e (Q0; Q1 on the falling edge after it) is in the cell's output register
# from edge e + 1; a fabric register takes it on edge e + 2.
#
# ODDRX1F: D0/D1 taken on edge E, passed on at E + 1, D0 driven on the pin
# while the clock is high from E + 2 (D1 while it is low). Amaranth's
# lowering says the same ("the ODDRX1F buffer has two additional pipeline
# stages"; only the OE gets registers of its own). So a pattern bit computed
# in the clock starting at edge c is registered at c + 1, registered again
# beside its pin at c + 2, taken by the cell at c + 3 and on the pin from
# edge c + 5 (PIN_LAG).
#
# Neither cell has a model in Yosys's ECP5 library (``cells_bb.v`` declares
# both as black boxes); ``sim/board_io.py`` models them register for register
# after Lattice's library and ``tests/test_cosim_board_io.py`` measures the
# whole path: an impulse on the ADC pins at sample k reaches the DAC pins at
# sample k + board_latency + COMMON_DELAY + DELAY[0].
# ---------------------------------------------------------------------------

#: IDDRX1F: edges from the one that samples a pin to the one on which the
#: fabric can take it (one output register inside the cell, plus that edge).
DDR_INPUT_LATENCY = 2
#: ODDRX1F: edges from the one that takes D0/D1 to the one from which D0 is on the pin.
DDR_OUTPUT_LATENCY = 2
#: Fabric clocks from the clock that computes a pin pattern bit to the edge
#: from which the pin shows it: the fabric register, the register beside the
#: pin, the cell's input edge, its two stages.
PIN_LAG = 3 + DDR_OUTPUT_LATENCY


def board_input_latency(slots: int) -> int:
    """Samples from an ADC pin sample to the period that accepts it: the ADC
    clock's rising edge on the pin (PIN_LAG after the period's first clock),
    the Q half M/2 fabric clocks later, the IDDRX1F, the sample register,
    then the next period start."""
    return -(-(PIN_LAG + DDR_INPUT_LATENCY + slots // 2) // slots)


def board_output_latency(contract: "ReplayContract") -> int:
    """Samples from the period that accepts input n to the one whose pattern
    drives output n on the DAC pins: the block's ``output_cycles``, the
    output FIFO, the DAC register (taken in a period's last clock)."""
    return -(-(contract.output_cycles + 2) // contract.slots)


#: Where a manifest is loaded: the board top (``rast.gateware.top.BoardTop``,
#: ADC and DAC pins, converters) or the bare replay block (its stream ports).
TARGETS = ("board", "block")


def board_latency(contract: "ReplayContract") -> int:
    """Samples from the ADC pins' sample to the DAC pins' sample of the board
    top (``rast.gateware.top``) at zero programmed delay, converters not
    included: the block's L, the input stage and the block's pipeline with
    the output stage. The pin patterns' PIN_LAG is on both sides and cancels."""
    return board_input_latency(contract.slots) + contract.latency + board_output_latency(contract)


def path_latency(contract: "ReplayContract", target: str, adc_latency: int = 0,
                 dac_latency: int = 0) -> int:
    """Fixed samples between a sample and its echo at zero programmed delay.

    ``"block"``: the replay block's ``L`` from its input to its output port.
    ``"board"``: from the analogue input of the ADC to the analogue output of
    the DAC: ``adc_latency + board_latency + dac_latency`` (the converters'
    own pipelines, in RTS samples, are not in the gateware; they come from
    the config's ``adc_latency``/``dac_latency``)."""
    if target not in TARGETS:
        raise ValueError(f"Target must be one of {', '.join(TARGETS)}, not {target!r}")
    if target == "block":
        return contract.latency
    return adc_latency + board_latency(contract) + dac_latency


def rate_mismatch(stream_rate_hz: float, block_rate_hz: float) -> str:
    """What streams made for ``stream_rate_hz`` do on a block sampling at
    ``block_rate_hz``: every Doppler scales by block / stream (the block steps
    through the words that much faster) and every range by its inverse;
    said as "N× too high" or "N× too low", N >= 1."""
    ratio = block_rate_hz / stream_rate_hz
    doppler, ranges = ("high", "short") if ratio >= 1 else ("low", "long")
    n = ratio if ratio >= 1 else 1 / ratio
    return f"every Doppler would play {n:.3g}x too {doppler} and every range {n:.3g}x too {ranges}"


def guard_bits(channels: int) -> int:
    """Guard bits of the channel sum: ``ceil(log2(channels))``."""
    return (channels - 1).bit_length()


def sum_width(channels: int) -> int:
    return SCALED_WIDTH + guard_bits(channels)


def round_half_up(v, shift: int):
    """``(v + 2**(shift-1)) >> shift`` on int64 numpy arrays or Python ints."""
    return (v + (1 << (shift - 1))) >> shift


def saturate(v, width: int = OUTPUT_WIDTH):
    """Clip to a signed ``width``-bit range; returns (clipped, overflowed)."""
    import numpy as np
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    v = np.asarray(v, dtype=np.int64)
    return np.clip(v, lo, hi), (v < lo) | (v > hi)


def _check_interpolation(interpolation):
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"Interpolation must be one of {', '.join(INTERPOLATIONS)}, not {interpolation!r}")


def pool_words_for(words: int) -> int:
    """The smallest valid ``pool_words`` holding ``words`` words."""
    if words <= POOL_BANK_WORDS:
        return max(16, 1 << (max(1, words) - 1).bit_length())
    return -(-words // POOL_BANK_WORDS) * POOL_BANK_WORDS


def cache_need_words(interpolation: str) -> int:
    """Cache words the consumer reads at one position: hold 1, linear 2, fir FIR_TAPS."""
    _check_interpolation(interpolation)
    return {"hold": 1, "linear": 2, "fir": FIR_TAPS}[interpolation]


def fetch_wait_samples(pipelines: int, slots: int = 1, fetch_cycles: int = POOL_FETCH_CYCLES,
                       queued_cycles: int = 0) -> int:
    """Samples after a switch by which CACHE_FILL_WORDS words are in the cache,
    at one period per sample (bubbles only give the fetcher more periods): the
    visit that restarts the fetcher, then each word at most one scan of
    ``pipelines`` periods, the last ``fetch_cycles`` more (the pool's latency
    bound), ``queued_cycles`` for the other channels' fetches queued before
    them (0 for the block-RAM pool, which serves one a clock), and one to spare."""
    return 1 + CACHE_FILL_WORDS * pipelines + -(-(fetch_cycles + queued_cycles) // slots) + 1


def refill_samples(interpolation: str, pipelines: int = 1, slots: int = 1,
                   fetch_cycles: int = POOL_FETCH_CYCLES, queued_cycles: int = 0) -> int:
    """Samples a channel is muted (phase held at 0) after a switch or reset:
    the cache fill, then (FIR) the first three U values."""
    _check_interpolation(interpolation)
    extra = FIR_REFILL_SAMPLES if interpolation == "fir" else 0
    return fetch_wait_samples(pipelines, slots, fetch_cycles, queued_cycles) + extra


def max_phase_increment(interpolation: str, pipelines: int = 1, word_samples: int | None = None) -> int:
    """Largest PHASE_INC the block accepts (larger values are clamped): the
    FIR's MAC limit, and for every interpolation at most one word per
    ``word_samples`` samples (default ``pipelines``: what the fetch scan
    supplies; the SDRAM pool asks more, ``ReplayContract.word_samples``)."""
    _check_interpolation(interpolation)
    scan = ((1 << PHASE_FRAC_BITS) - 1) // (pipelines if word_samples is None else word_samples)
    return min(FIR_MAX_INCREMENT, scan) if interpolation == "fir" else scan


def delay_depth(max_delay: int) -> int:
    """Words of a delay line's RAM: the power of two >= ``max_delay + 2``
    (the read address trails the write address by ``delay + 1``)."""
    return 1 << max(1, (max_delay + 1).bit_length())


def min_stream_length(interpolation: str) -> int:
    """Shortest LENGTH the block accepts (shorter values are clamped)."""
    _check_interpolation(interpolation)
    return FIR_MIN_LENGTH if interpolation == "fir" else 1


@dataclass(frozen=True)
class ReplayContract:
    """Elaboration-time parameters of the replay block and everything derived.

    Parameters
    ----------
    channels : int
        Number of windmill channels N (1 to MAX_CHANNELS).
    slots : int
        M, fabric clocks per RTS sample: each pipeline serves M channels, one
        per clock (``pipelines`` = ceil(N / M) of them). 1 for a radar whose
        sample rate is the fabric clock.
    pool_words : int
        Words of the stream pool, shared by all channels' streams: a power
        of two from 16 to POOL_BANK_WORDS, or a multiple of POOL_BANK_WORDS.
    max_delay : int
        Largest programmable common delay (COMMON_DELAY), samples: the delay
        line every channel shares, up to the nearest turbine.
    max_tap : int
        Largest programmable tap (DELAY of every channel), samples: each
        channel reads the common line's output this many samples later from
        its pipeline's copy of the window line, so a farm may be ``max_tap``
        samples deep and any number of channels may share a tap.
    interpolation : str
        ``"fir"`` (default, images below -70 dB), ``"linear"`` or ``"hold"``
        (see the interpolation section above).
    cmult_form : str
        ``"4mult"`` or ``"3mult"`` complex multiplier (identical results).
    sample_rate_hz : int
        RTS sample rate the block is built for (register SAMPLE_RATE); 0 when
        not stated (simulation). It changes no arithmetic of a block-RAM
        pool; an SDRAM pool's bounds (refill, highest stream rate) are in
        controller clocks and follow the fabric clock it gives.
    pool : str
        Where the stream pool lives: ``"bram"`` (block RAM, default) or
        ``"sdram"`` (the board's SDRAM; a power of two up to
        SDRAM_MAX_POOL_WORDS words, longer refills and a lower highest
        stream rate: see the SDRAM section above).
    scan : bool
        The antenna scan is built in: the beam's azimuth (free running or
        from the radar's ACP/ARP), a per-channel AZIMUTH and each channel's
        gain times the two-way pattern at the beam's offset
        (``rast.model.contract.scan``; docs/antenna_scan.md). Off: the
        block and its register map are what they were without it.
    start_frac : bool
        Each channel has a START register: a switched-in stream starts at
        that fraction of its first word instead of at the word (with a
        stream rolled by whole words in the pool, at any phase): what a
        channel that follows the beam needs (docs/beam_following.md). Needs
        the scan's register map. Off: the block is what it was without it.
    follow_rows : int
        Channels that follow the beam (docs/beam_following.md): the turbine
        table's rows (0: none). Needs ``start_frac``.
    """
    channels: int = 4
    slots: int = 1
    pool_words: int = 65536
    max_delay: int = 4094
    max_tap: int = 1022
    interpolation: str = "fir"
    cmult_form: str = "4mult"
    sample_rate_hz: int = 0
    pool: str = "bram"
    scan: bool = False
    start_frac: bool = False
    follow_rows: int = 0

    #: Keys of :meth:`to_dict` that are constructor parameters.
    PARAMETERS = ("channels", "slots", "pool_words", "max_delay", "max_tap", "interpolation",
                  "cmult_form", "sample_rate_hz", "pool", "scan", "start_frac", "follow_rows")
    #: Most rows of a turbine table.
    MAX_FOLLOW_ROWS = 4096
    #: Most channels a block may have: 8 pipelines of 64 slots, an air-traffic
    #: radar's rate on the 160 MHz fabric (CONFIG holds up to 2047).
    MAX_CHANNELS = 512
    #: Most slots per pipeline.
    MAX_SLOTS = 64

    def __post_init__(self):
        def posint(name, what, v, lo=1, hi=None):
            kind = ("a positive integer" if lo == 1 else "a non-negative integer" if lo == 0
                    else f"an integer of at least {lo}")
            if not isinstance(v, int) or isinstance(v, bool):
                raise TypeError(f"{what} must be {kind}, not {v!r}")
            if v < lo:
                raise ValueError(f"{what} must be {kind}, not {v!r}")
            if hi is not None and v > hi:
                raise ValueError(f"{what} must be at most {hi}, not {v!r}")
        posint("channels", "Channel count", self.channels, 1, self.MAX_CHANNELS)
        posint("slots", "Slots per pipeline", self.slots, 1, self.MAX_SLOTS)
        for name in ("scan", "start_frac"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be True or False, not {getattr(self, name)!r}")
        if self.start_frac and not self.scan:
            raise ValueError("start_frac needs scan: START lies in the scan build's channel blocks")
        posint("follow_rows", "Follow rows", self.follow_rows, 0, self.MAX_FOLLOW_ROWS)
        if self.follow_rows and not self.start_frac:
            raise ValueError("follow_rows needs start_frac: a following channel starts its turbine's stream "
                             "at a phase")
        if self.pool not in POOL_BACKENDS:
            raise ValueError(f"Pool must be one of {', '.join(POOL_BACKENDS)}, not {self.pool!r}")
        w = self.pool_words
        if self.pool == "sdram":
            posint("pool_words", "Pool words", w, 16, SDRAM_MAX_POOL_WORDS)
            if w & (w - 1):
                raise ValueError(f"Pool words of an SDRAM pool must be a power of two from 16 to "
                                 f"{SDRAM_MAX_POOL_WORDS}, not {w!r}")
        else:
            posint("pool_words", "Pool words", w, 16, 1 << 20)
            if not (w % POOL_BANK_WORDS == 0 if w > POOL_BANK_WORDS else not w & (w - 1)):
                raise ValueError(f"Pool words must be a power of two from 16 to {POOL_BANK_WORDS} or a "
                                 f"multiple of {POOL_BANK_WORDS}, not {w!r}")
        posint("max_delay", "Maximum delay", self.max_delay, 1, 1 << 20)
        posint("max_tap", "Maximum tap", self.max_tap, 1, 1 << 20)
        _check_interpolation(self.interpolation)
        if self.cmult_form not in CMULT_FORMS:
            raise ValueError(f"Complex multiplier form must be one of 4mult, 3mult, not {self.cmult_form!r}")
        posint("sample_rate_hz", "Sample rate", self.sample_rate_hz, 0, (1 << 32) - 1)

    def to_dict(self) -> dict:
        """What a block built with this contract is: its parameters and what
        follows from them (``report.json``'s ``build``, read by ``rast stream
        --build``)."""
        return {**{k: getattr(self, k) for k in self.PARAMETERS},
                "pipelines": self.pipelines,
                "clock_hz": self.clock_hz,
                "latency_samples": self.latency,
                "board_latency_samples": self.board_latency,
                "max_phase_increment": self.max_phase_increment,
                "min_stream_length": self.min_stream_length,
                "refill_samples": self.refill_samples}

    @classmethod
    def from_dict(cls, d: dict) -> "ReplayContract":
        """Inverse of :meth:`to_dict` (derived keys are ignored)."""
        return cls(**{k: d[k] for k in cls.PARAMETERS if k in d})

    @property
    def pipelines(self) -> int:
        """P = ceil(N / M): the physical pipelines (each with its multipliers,
        window copy and word cache)."""
        return -(-self.channels // self.slots)

    @property
    def clock_hz(self) -> int:
        """The fabric clock: ``slots`` x ``sample_rate_hz`` (0 when the rate is not stated)."""
        return self.slots * self.sample_rate_hz

    @property
    def guard_bits(self) -> int:
        return guard_bits(self.channels)

    @property
    def sum_width(self) -> int:
        return sum_width(self.channels)

    def _fabric_cycles(self, sdram_clocks: int) -> int:
        """Controller clocks of the SDRAM in fabric clocks (rounded up)."""
        fabric_hz = self.clock_hz or SDRAM_FABRIC_HZ
        return -(-sdram_clocks * fabric_hz // SDRAM_CLOCK_HZ)

    @property
    def pool_fetch_cycles(self) -> int:
        """Fabric clocks from a granted fetch to its word in the cache, at most:
        POOL_FETCH_CYCLES for block RAM; for SDRAM that path plus
        :func:`sdram_fetch_clocks` in fabric clocks."""
        if self.pool == "bram":
            return POOL_FETCH_CYCLES
        return POOL_FETCH_CYCLES + self._fabric_cycles(sdram_fetch_clocks())

    #: Fabric clocks PoolReadCheck adds per word to the pool's: its request
    #: register and the four CRC clocks.
    POOL_CHECK_EXTRA_CYCLES = 6

    def pool_check_seconds(self, words: int) -> float:
        """Longest an SDRAM pool's POOL_CHECK of ``words`` words may take: a
        word at a time, each within the fetch bound (behind whatever the
        channels fetch, refresh and host writes)."""
        fabric_hz = self.clock_hz or SDRAM_FABRIC_HZ
        return int(words) * (self.pool_fetch_cycles + self.POOL_CHECK_EXTRA_CYCLES) / fabric_hz

    @property
    def pool_word_cycles(self) -> int:
        """Fabric clocks the pool may take per fetched word under load: 1 for
        block RAM; for SDRAM twice SDRAM_WORD_CLOCKS (the host's writes take
        every other turn)."""
        return 1 if self.pool == "bram" else self._fabric_cycles(2 * SDRAM_WORD_CLOCKS)

    @property
    def word_samples(self) -> int:
        """Samples per stream word at the highest stream rate: one scan of
        ``pipelines`` periods for block RAM; for SDRAM also the bandwidth
        (every channel at this rate) and the latency (a word asked when one is
        released is needed CACHE_FILL_WORDS - need - 1 releases later)."""
        if self.pool == "bram":
            return self.pipelines
        M = self.slots
        bandwidth = -(-self.channels * self.pool_word_cycles // M)
        fetch = self.pipelines + -(-self.pool_fetch_cycles // M) + 1
        lead = CACHE_FILL_WORDS - cache_need_words(self.interpolation) - 1
        return max(self.pipelines, bandwidth, -(-fetch // lead))

    @property
    def refill_samples(self) -> int:
        queued = 0 if self.pool == "bram" else self.channels * (CACHE_FILL_WORDS + 1) * self.pool_word_cycles
        return refill_samples(self.interpolation, self.pipelines, self.slots, self.pool_fetch_cycles, queued)

    @property
    def max_phase_increment(self) -> int:
        return max_phase_increment(self.interpolation, self.pipelines, self.word_samples)

    @property
    def pool_address_width(self) -> int:
        """Bits of a pool address (BASE, STREAM_ADDR)."""
        return (self.pool_words - 1).bit_length()

    @property
    def max_stream_length(self) -> int:
        """Longest LENGTH: the whole pool."""
        return self.pool_words

    @property
    def min_stream_length(self) -> int:
        return min_stream_length(self.interpolation)

    @property
    def latency(self) -> int:
        """Fixed latency L in samples: an echo of channel l appears ``L +
        COMMON_DELAY + DELAY[l]`` samples after its input (BLOCK_LATENCY)."""
        return BLOCK_LATENCY

    @property
    def output_cycles(self) -> int:
        """Fabric clocks from accepting input n to output n in the saturation
        register (:func:`engine_output_cycles`)."""
        return engine_output_cycles(self.slots, self.pipelines, self.cmult_form)

    @property
    def board_latency(self) -> int:
        """Samples from the ADC pins' sample to the DAC pins' sample on the
        board top at zero programmed delay (converters not included, see
        :func:`path_latency`)."""
        return board_latency(self)

    @property
    def common_depth(self) -> int:
        """Words of the common delay line's RAM (power of two >= max_delay + 2)."""
        return delay_depth(self.max_delay)

    @property
    def window_depth(self) -> int:
        """Words of each pipeline's window RAM (power of two >= max_tap + 2)."""
        return delay_depth(self.max_tap)

    @property
    def length_width(self) -> int:
        return self.pool_words.bit_length()
