"""How many replay channels (turbines) an ECP5 holds: block RAM and DSP budget.

Counts follow the primitives the build uses (``rast.hdl.ecp5_primitives``):
the stream pool of ``pool_words`` 32-bit words is width-sliced over DP16KD
(16384 words deep at 1 bit, 8192 at 2, ...; deeper pools are banks of 16384);
the common delay line is one RAM; per channel, its copy of the delay window
is one RAM and the FIR interpolator's coefficient ROM (512 x 18) one DP16KD; the channels' word caches (16 words)
are distributed RAM. The complex product and the gain use 6 MULT18X18D;
linear interpolation 2 more, the FIR 4 more (its MAC and its linear step, I
and Q).
"""

from ..hdl.ecp5_primitives import dp16kd_mode
from ..model.fixedpoint import ReplayContract, POOL_BANK_WORDS, pool_words_for, min_stream_length

__all__ = ["ram_blocks", "pool_blocks", "common_blocks", "channel_blocks", "total_blocks", "channel_dsps",
           "max_channels", "turbines_per_device", "DEVICE_BLOCKS", "DSP_PER_CHANNEL"]

#: (DP16KD, MULT18X18D) per device (Lattice ECP5 family data sheet, table 1.1).
DEVICE_BLOCKS = {"LFE5U-12F": (32, 28), "LFE5U-25F": (56, 28), "LFE5U-45F": (108, 72),
                 "LFE5U-85F": (208, 156)}
#: MULT18X18D per channel: complex product and gain, then the interpolator's.
DSP_PER_CHANNEL = 6
_INTERP_DSPS = {"hold": 0, "linear": 2, "fir": 4}
_INTERP_ROMS = {"hold": 0, "linear": 0, "fir": 1}


def ram_blocks(width, depth):
    mode = dp16kd_mode(width, depth)
    if mode is not None:
        return mode[1]
    return -(-depth // 512) * -(-width // 36)          # inferred 512 x 36 cascade


def pool_blocks(contract: ReplayContract) -> int:
    """DP16KD of the stream pool."""
    bank = min(contract.pool_words, POOL_BANK_WORDS)
    return contract.pool_words // bank * ram_blocks(32, bank)


def common_blocks(contract: ReplayContract) -> int:
    """DP16KD of the common delay line."""
    return ram_blocks(32, contract.common_depth)


def channel_blocks(contract: ReplayContract) -> int:
    """DP16KD of one channel: its window copy, its interpolator ROM."""
    return ram_blocks(32, contract.window_depth) + _INTERP_ROMS[contract.interpolation]


def total_blocks(contract: ReplayContract) -> int:
    """DP16KD of the replay block: the pool, the common line and every channel."""
    return pool_blocks(contract) + common_blocks(contract) + contract.channels * channel_blocks(contract)


def channel_dsps(contract: ReplayContract) -> int:
    """MULT18X18D of one channel."""
    return DSP_PER_CHANNEL + _INTERP_DSPS[contract.interpolation]


def max_channels(device="LFE5U-85F", **contract_kwargs):
    """(largest N that fits, what limits it) for a contract's depths on ``device``."""
    brams, dsps = DEVICE_BLOCKS[device]
    n = 0
    while n < 64:
        c = ReplayContract(channels=n + 1, **contract_kwargs)
        need_b = total_blocks(c)
        need_d = channel_dsps(c) * (n + 1)
        if need_b > brams or need_d > dsps:
            return n, ("block RAM" if need_b > brams else "DSP")
        n += 1
    return n, "channel limit"


def turbines_per_device(words, device="LFE5U-85F", interpolation="fir", **contract_kwargs):
    """``(turbines, pool_words, limit)``: the most turbines of ``words`` stream
    words each that one ``device`` replays at once from block RAM, each on a
    channel of its own, with room in the pool to reload one while all play;
    ``limit`` names what stops one more."""
    brams, dsps = DEVICE_BLOCKS[device]
    words = max(words, min_stream_length(interpolation))
    best, pool, limit = 0, None, "channel limit"
    for n in range(1, 65):
        need = pool_words_for((n + 1) * words)
        c = ReplayContract(channels=n, pool_words=need, interpolation=interpolation, **contract_kwargs)
        if channel_dsps(c) * n > dsps:
            limit = "DSP"
            break
        if total_blocks(c) > brams:
            limit = "block RAM"
            break
        best, pool = n, need
    return best, pool, limit
