"""``rast verilog``: the wind-farm replay top as Verilog, and its Verilator lint.

The command line only: the Verilog, the lint and the waived Verilator warning
classes are :mod:`rast.gateware.verilog`'s.
"""

import argparse
import re
import sys
from pathlib import Path

__all__ = ["add_arguments", "run", "main"]


def add_arguments(parser: argparse.ArgumentParser):
    from rast.options import add_replay_arguments
    add_replay_arguments(parser, channels=4)
    parser.add_argument("--manifest", type=Path,
                        help="bake the streams and registers of this `rast stream` manifest "
                             "(manifest.json or its folder) into the power-up state")
    parser.add_argument("--scan", action="store_true",
                        help="with the antenna scan (ports acp, arp; docs/antenna_scan.md); it powers up "
                             "staring, a host loads its table (rast load)")
    parser.add_argument("--name", default="wind_farm_replay", help="Verilog module name")
    parser.add_argument("--lint", action="store_true", help="run Verilator --lint-only -Wall after")
    parser.add_argument("-o", "--output", type=Path, required=True, help="Verilog file to write")


def run(args):
    """Write the Verilog; every mistake in the arguments or the manifest raises
    :class:`rast.errors.UserError` before the output is touched."""
    from rast.errors import UserError, check_output, manifest_streams, read_manifest
    from rast.gateware.verilog import lint, write_verilog
    from rast.model.contract.fixedpoint import ReplayContract
    from rast.options import replay_kwargs
    kwargs = {**replay_kwargs(args), **({"scan": True} if args.scan else {})}
    try:
        contract = ReplayContract(channels=args.channels, **kwargs)
    except ValueError as error:
        raise UserError(f"bad replay block parameters: {error}") from None
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_$]*", args.name):
        raise UserError(f"--name {args.name!r} is not a Verilog identifier")
    check_output(args.output, folder=False, option="--output")
    extra = []
    if args.manifest:
        from rast.model.contract.loadplan import manifest_channel_inits
        manifest, manifest_file = read_manifest(args.manifest)
        streams = manifest_streams(manifest, manifest_file.parent)
        try:
            kwargs["init"], kwargs["init_common_delay"] = manifest_channel_inits(manifest, contract,
                                                                                  streams=streams)
        except ValueError as error:
            raise UserError(f"the manifest {manifest_file} does not fit a block of {contract.channels} "
                            f"channel(s), pool words {contract.pool_words}, maximum delay "
                            f"{contract.max_delay}, maximum tap {contract.max_tap}: "
                            f"{error}") from None
        extra.append(f"initial contents from {manifest_file.name}: "
                     + ", ".join(ch["windmill"] for ch in manifest["registers"]["channels"]))
    try:
        path = write_verilog(args.channels, args.output, name=args.name, header_extra=extra, **kwargs)
    except OSError as error:
        raise UserError(f"cannot write {args.output}: {error.strerror or error}") from None
    print(f"wrote {path}")
    if args.lint:
        lint(path, args.name)
        print("verilator lint: clean")
    return 0


def main(argv=None):
    """``python -m rast.verilog ARGS`` is ``rast verilog ARGS`` (exit status 2 on a user error)."""
    from rast.cli import main as cli_main
    return cli_main(["verilog", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
