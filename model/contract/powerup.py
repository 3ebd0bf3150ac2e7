"""The replay block's power-up state: what each channel plays and its
registers hold before any host writes (``rast verilog --manifest`` bakes a
manifest in; the model and the gateware start from the same)."""

from dataclasses import dataclass

__all__ = ["ChannelInit", "pool_contents"]


@dataclass(frozen=True)
class ChannelInit:
    """Power-up contents of one channel: its stream's words (in the pool from
    ``base`` on) and register resets."""
    words: tuple = ()
    phase_increment: int = 0
    gain: int = 0
    delay: int = 0
    enable: bool = False
    base: int = 0
    #: AZIMUTH's reset (a block built with the scan): the turbine's azimuth
    #: code, 2**16 a revolution clockwise from north.
    azimuth: int = 0

    @property
    def length(self) -> int:
        return max(1, len(self.words))


def pool_contents(inits, pool_words: int) -> list:
    """The pool's power-up words from channels' :class:`ChannelInit` (each
    stream from its ``base`` on); channels may share words, not overwrite
    each other's."""
    pool = [None] * pool_words
    for ch, ini in enumerate(inits):
        if ini.base < 0 or ini.base + len(ini.words) > pool_words:
            raise ValueError(f"Initial stream of channel {ch} ({len(ini.words)} words from "
                             f"{ini.base}) must lie inside the pool of {pool_words} words")
        for k, w in enumerate(ini.words):
            w = int(w) & 0xFFFFFFFF
            if pool[ini.base + k] not in (None, w):
                raise ValueError(f"Initial stream of channel {ch} overwrites another channel's word "
                                 f"at pool address {ini.base + k}")
            pool[ini.base + k] = w
    return [0 if w is None else w for w in pool]

