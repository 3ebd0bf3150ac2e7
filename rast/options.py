"""Command-line options shared by subcommands: the replay block's parameters."""

from __future__ import annotations

__all__ = ["REPLAY_OPTIONS", "add_replay_arguments", "replay_kwargs"]

#: The :class:`rast.model.contract.fixedpoint.ReplayContract` parameters the options set (but ``channels``).
REPLAY_OPTIONS = ("pool_words", "max_delay", "max_tap", "interpolation", "cmult_form")
#: ``slots`` too, where the command takes it directly (not from clocks).


def add_replay_arguments(parser, *, channels: int, defaults=None, slots: bool = True) -> None:
    """Add ``--channels`` (default ``channels``), ``--slots`` (unless
    ``slots`` is false: the command derives it from its clocks),
    ``--pool-words``, ``--max-delay``, ``--max-tap``, ``--interpolation`` and
    ``--cmult-form`` to ``parser`` (a parser or an argument group); the
    defaults are ``defaults``' (any object with those attributes) or
    :class:`ReplayContract`'s."""
    from rast.model.contract.fixedpoint import ReplayContract
    d = defaults or ReplayContract()
    parser.add_argument("--channels", type=int, default=channels,
                        help=f"windmill channels N (default {channels})")
    if slots:
        parser.add_argument("--slots", type=int, default=1,
                            help="fabric clocks per sample M: each pipeline serves M channels, one per "
                                 "clock (default 1)")
    parser.add_argument("--pool-words", type=int, default=d.pool_words,
                        help=f"words of the stream pool shared by all channels (default {d.pool_words})")
    parser.add_argument("--max-delay", type=int, default=d.max_delay,
                        help=f"largest common delay, samples (default {d.max_delay})")
    parser.add_argument("--max-tap", type=int, default=d.max_tap,
                        help=f"largest tap (DELAY) of a channel beyond the common delay, samples (default {d.max_tap})")
    parser.add_argument("--interpolation", choices=("fir", "linear", "hold"), default=d.interpolation,
                        help="stream interpolation: fir (default, images below -70 dB), linear, "
                             "or hold (exact for one word per sample)")
    parser.add_argument("--cmult-form", choices=("4mult", "3mult"), default=d.cmult_form,
                        help=f"complex multiplier form, same results (default {d.cmult_form})")


def replay_kwargs(args) -> dict:
    """The replay block's parameters from parsed options, ``channels`` left out
    (``slots`` in, where the command has the option)."""
    out = {name: getattr(args, name) for name in REPLAY_OPTIONS}
    if hasattr(args, "slots"):
        out["slots"] = args.slots
    return out
