"""How many replay channels (turbines) an ECP5 holds: block RAM and DSP budget.

Counts follow the primitives the build uses (``rast.hdl.ecp5_primitives``):
the stream pool of ``pool_words`` 32-bit words is width-sliced over DP16KD
(16384 words deep at 1 bit, 8192 at 2, ...; deeper pools are banks of 16384);
the common delay line is one RAM; per pipeline (``ReplayContract.pipelines``,
M channels each) its copy of the delay window is one RAM. The FIR's
coefficient ROM and the word caches are distributed RAM. A pipeline's
complex product uses 4 MULT18X18D (3 in the 3-multiplier form) and its gain
2; linear interpolation 2 more (its step), the FIR 4 more (its MAC and its
step, I and Q).
"""

from ..hdl.ecp5_primitives import dp16kd_mode
from rast.model.contract.fixedpoint import ReplayContract, POOL_BANK_WORDS, pool_words_for, min_stream_length

__all__ = ["ram_blocks", "pool_blocks", "common_blocks", "pipeline_blocks", "total_blocks",
           "pipeline_dsps", "total_dsps", "max_channels", "turbines_per_device", "DEVICE_BLOCKS"]

#: (DP16KD, MULT18X18D) per device (Lattice ECP5 family data sheet, table 1.1).
DEVICE_BLOCKS = {"LFE5U-12F": (32, 28), "LFE5U-25F": (56, 28), "LFE5U-45F": (108, 72),
                 "LFE5U-85F": (208, 156)}
_CMULT_DSPS = {"4mult": 4, "3mult": 3}
_INTERP_DSPS = {"hold": 0, "linear": 2, "fir": 4}


def ram_blocks(width, depth):
    mode = dp16kd_mode(width, depth)
    if mode is not None:
        return mode[1]
    return -(-depth // 512) * -(-width // 36)          # inferred 512 x 36 cascade


def pool_blocks(contract: ReplayContract) -> int:
    """DP16KD of the stream pool (none when it is in SDRAM)."""
    if contract.pool == "sdram":
        return 0
    bank = min(contract.pool_words, POOL_BANK_WORDS)
    return contract.pool_words // bank * ram_blocks(32, bank)


def common_blocks(contract: ReplayContract) -> int:
    """DP16KD of the common delay line."""
    return ram_blocks(32, contract.common_depth)


def pipeline_blocks(contract: ReplayContract) -> int:
    """DP16KD of one pipeline: its window copy."""
    return ram_blocks(32, contract.window_depth)


def total_blocks(contract: ReplayContract) -> int:
    """DP16KD of the replay block: the pool, the common line and every pipeline."""
    return pool_blocks(contract) + common_blocks(contract) + contract.pipelines * pipeline_blocks(contract)


def pipeline_dsps(contract: ReplayContract) -> int:
    """MULT18X18D of one pipeline."""
    return _CMULT_DSPS[contract.cmult_form] + 2 + _INTERP_DSPS[contract.interpolation]


def total_dsps(contract: ReplayContract) -> int:
    return contract.pipelines * pipeline_dsps(contract)


def max_channels(device="LFE5U-85F", **contract_kwargs):
    """(largest N that fits, what limits it) for a contract's slots and depths on ``device``."""
    brams, dsps = DEVICE_BLOCKS[device]
    n = 0
    while n < ReplayContract.MAX_CHANNELS:
        c = ReplayContract(channels=n + 1, **contract_kwargs)
        need_b, need_d = total_blocks(c), total_dsps(c)
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
    for n in range(1, ReplayContract.MAX_CHANNELS + 1):
        need = pool_words_for((n + 1) * words)
        c = ReplayContract(channels=n, pool_words=need, interpolation=interpolation, **contract_kwargs)
        if total_dsps(c) > dsps:
            limit = "DSP"
            break
        if total_blocks(c) > brams:
            limit = "block RAM"
            break
        best, pool = n, need
    return best, pool, limit
