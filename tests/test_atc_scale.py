"""The air-traffic scale (issue: 512 turbines for an air-traffic radar):
what the host and the contract need for more than 255 channels."""

import pytest

from rast.model.contract.fixedpoint import ReplayContract


@pytest.mark.parametrize("channels, slots", [(64, 8), (300, 64), (512, 64)])
def test_the_loader_reads_channel_counts_beyond_255_from_config(channels, slots):
    """CONFIG holds N's low 8 bits and, in channels_hi (only in a build of
    more than 255), the rest (512 channels at 64 slots: the air-traffic build)."""
    from rast.load import _read_contract
    from rast.model.contract.hostproto import BRIDGE_ID
    from rast.model.contract.regmap import register_map

    contract = ReplayContract(channels=channels, slots=slots, pool="sdram", pool_words=1 << 23,
                              sample_rate_hz=2_500_000)
    rmap = register_map(contract)

    class Board:                      # answers every read with the register's power-up value
        def version(self):
            return BRIDGE_ID

        def read(self, addr):
            r = rmap.by_addr(addr)
            return sum(f.reset << f.lsb for f in r.fields if f.access == "ro")

    hi = [f.reset for f in rmap.reg("CONFIG").fields if f.name == "channels_hi"]
    assert hi == ([channels >> 8] if channels > 255 else [])      # (no field, no change, up to 255)
    assert _read_contract(Board()) == contract
