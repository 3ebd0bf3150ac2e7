"""How many replay channels (turbines) an ECP5 holds: block RAM and DSP budget.

Counts follow the primitives the build uses (``rast.hdl.ecp5_primitives``):
a channel's stream RAM holds two banks of ``stream_depth`` 32-bit words,
width-sliced over DP16KD (16384 words deep at 1 bit, 8192 at 2, ...; beyond
16384 words Yosys's inference cascades 512 x 36 blocks), twice with linear
interpolation (it reads two words per sample); its delay segment is one more
RAM; the FIR interpolator's coefficient ROM (512 x 18) one DP16KD. The
complex product and the gain use 6 MULT18X18D; linear interpolation 2 more,
the FIR 4 more (its MAC and its linear step, I and Q).
"""

from ..hdl.ecp5_primitives import dp16kd_mode
from ..model.fixedpoint import ReplayContract

__all__ = ["ram_blocks", "channel_blocks", "channel_dsps", "max_channels", "DEVICE_BLOCKS",
           "DSP_PER_CHANNEL"]

#: (DP16KD, MULT18X18D) per device (Lattice ECP5 family data sheet, table 1.1).
DEVICE_BLOCKS = {"LFE5U-12F": (32, 28), "LFE5U-25F": (56, 28), "LFE5U-45F": (108, 72),
                 "LFE5U-85F": (208, 156)}
#: MULT18X18D per channel: complex product and gain, then the interpolator's.
DSP_PER_CHANNEL = 6
_INTERP_DSPS = {"hold": 0, "linear": 2, "fir": 4}
_STREAM_COPIES = {"hold": 1, "linear": 2, "fir": 1}
_INTERP_ROMS = {"hold": 0, "linear": 0, "fir": 1}


def ram_blocks(width, depth):
    mode = dp16kd_mode(width, depth)
    if mode is not None:
        return mode[1]
    return -(-depth // 512) * -(-width // 36)          # inferred 512 x 36 cascade


def channel_blocks(contract: ReplayContract, channel: int) -> int:
    """DP16KD of one channel: stream RAM (2 banks, per copy), delay segment,
    interpolator ROM."""
    i = contract.interpolation
    return (_STREAM_COPIES[i] * ram_blocks(32, 2 * contract.stream_depth)
            + ram_blocks(32, contract.delay_depth(channel)) + _INTERP_ROMS[i])


def channel_dsps(contract: ReplayContract) -> int:
    """MULT18X18D of one channel."""
    return DSP_PER_CHANNEL + _INTERP_DSPS[contract.interpolation]


def max_channels(device="LFE5U-85F", **contract_kwargs):
    """(largest N that fits, what limits it) for a contract's depths on ``device``."""
    brams, dsps = DEVICE_BLOCKS[device]
    n = 0
    while n < 64:
        c = ReplayContract(channels=n + 1, **contract_kwargs)
        need_b = sum(channel_blocks(c, l) for l in range(n + 1))
        need_d = channel_dsps(c) * (n + 1)
        if need_b > brams or need_d > dsps:
            return n, ("block RAM" if need_b > brams else "DSP")
        n += 1
    return n, "channel limit"
