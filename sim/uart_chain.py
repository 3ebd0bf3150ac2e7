"""The load chain through the bitstream's top: ``rast load``'s conversation
replayed into the board's replay system (UART bridge + replay block) in
Verilator, every output sample checked against the bit-exact model.

``rast load`` talks to a board interactively (it waits for each reply), so
the conversation is first held with a stand-in board answering from the
bit-exact model (:class:`ModelBoard`): what the host sends is then known byte
for byte, and what the gateware must answer too. ``rast_uart_chain.v`` sends
those bytes into the simulated bridge (with the idle time the host would
spend waiting for each reply), feeds input samples every clock, and records
the bridge's bytes, every bus write with the sample from which it takes
effect, and the output samples; :func:`run_chain` compares them all.
"""

from __future__ import annotations

import hashlib
import shutil
import struct
import subprocess
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from rast.model.contract.datapath import ReplayModel
from rast.model.contract.fixedpoint import WRITE_STAGING, unpack_iq
from rast.model.contract.hostproto import ACK, BRIDGE_ID, CMD_BURST, CMD_READ, CMD_VERSION, CMD_WRITE

__all__ = ["ModelBoard", "ChainResult", "run_chain", "host_clocks", "weighted_sums", "burst_train",
           "check_chain", "SDRAMLoadChain", "sdram_load_chain"]

#: Idle bit times the host leaves after a read or version frame (the 4 reply
#: bytes, 40 bit times, come back before it sends on, as rast load waits).
REPLY_WAIT_BITS = 60


class ModelBoard:
    """A transport for :class:`~rast.model.contract.hostproto.HostBridge` that answers
    from a :class:`ReplayModel` and records the conversation."""

    def __init__(self, model: ReplayModel, divisor: int | None = None):
        self.model = model
        self.sent = []          # (byte, idle bit times before it)
        self.applied = []       # register writes, (addr, value), in order
        self.replies = bytearray()
        self._pending = bytearray()
        self._buf = bytearray()
        self._gap = 0
        # With ``divisor`` (fabric clocks per bit) time passes on the board as
        # on the line: the model plays (on a silent input) up to each read, the
        # writes taking effect at the sample their command ends, so a switch
        # waiting for its stream's wrap is taken when the block would take it.
        self.divisor = divisor
        self._clocks = 0        # fabric clocks the host's bytes have taken
        self._played = 0        # samples the model has run
        self._queue = []        # (sample, addr, value) written, not yet run

    def write(self, data):
        for b in bytes(data):
            self.sent.append((b, self._gap))
            if self.divisor:
                self._clocks += host_clocks([(b, self._gap)], self.divisor)
            self._gap = 0
            self._buf.append(b)
            self._parse()

    def _parse(self):
        buf = self._buf
        while buf:
            cmd = buf[0]
            if cmd == CMD_VERSION:
                del buf[:1]
                self._reply(struct.pack("<I", BRIDGE_ID), wait=True)
            elif cmd == CMD_READ:
                if len(buf) < 3:
                    return
                addr = struct.unpack_from("<H", buf, 1)[0]
                del buf[:3]
                self._play_to_now()
                self._reply(struct.pack("<I", self.model.read(addr)), wait=True)
            elif cmd == CMD_WRITE:
                if len(buf) < 7:
                    return
                addr, value = struct.unpack_from("<HI", buf, 1)
                del buf[:7]
                self._apply(addr, value)
                self._reply(bytes([ACK]))
            elif cmd == CMD_BURST:
                if len(buf) < 5:
                    return
                addr, n = struct.unpack_from("<HH", buf, 1)
                if len(buf) < 5 + 4 * n:
                    return
                for k in range(n):
                    self._apply(addr, struct.unpack_from("<I", buf, 5 + 4 * k)[0])
                del buf[:5 + 4 * n]
                self._reply(bytes([ACK]))
            else:
                raise AssertionError(f"rast load sent a byte that is no command: {cmd:#04x}")

    def idle(self, bit_times: int):
        """The host sends nothing for ``bit_times`` more bit times before its next byte."""
        self._gap += int(bit_times)

    def _apply(self, addr, value):
        if self.divisor:
            self._queue.append((self._clocks // self.model.c.slots, addr, value))
        else:
            self.model.write(addr, value)
        self.applied.append((addr, value))

    def _play_to_now(self):
        """A timed board: run the model up to the sample the host is at."""
        if not self.divisor:
            return
        n = max(0, self._clocks // self.model.c.slots - self._played)
        silent = np.zeros(n, dtype=np.int64)
        self.model.run_with_writes(silent, silent, [(s - self._played, a, v) for s, a, v in self._queue])
        self._played += n
        self._queue = []

    def _reply(self, data, wait=False):
        self._pending += data
        self.replies += data
        if wait:
            self._gap = REPLY_WAIT_BITS

    def read(self, n):
        out = bytes(self._pending[:n])
        del self._pending[:n]
        return out


def host_clocks(sent, divisor) -> int:
    """Clocks ``rast_uart_chain.v`` takes to send ``sent``: per byte its idle
    bit times, 10 bits and 2 idle clocks."""
    return sum((gap + 10) * divisor + 2 for _, gap in sent)


@dataclass
class ChainResult:
    steps: int                 # input samples simulated
    writes: list               # (step, addr, data): every bus write and its step
    tx: bytes                  # what the bridge sent
    sums: dict                 # position-weighted sums of every output, from the RTL
    tail: np.ndarray           # (n, 2) the last output samples, from the RTL
    tail_from: int


def _build(sources: dict, work: Path, defines=(), jobs: int = 2) -> Path:
    from rast.gateware.verilog import build_verilated
    h = hashlib.sha256(" ".join(defines).encode())
    for name in sorted(sources):
        h.update(name.encode() + sources[name].encode())
    bdir = work / f"uart_chain-{h.hexdigest()[:16]}"
    exe = bdir / "obj_dir" / "Vrast_uart_chain"
    if exe.exists():
        return exe
    shutil.rmtree(bdir, ignore_errors=True)
    bdir.mkdir(parents=True)
    for name, text in sources.items():
        (bdir / name).write_text(text)
    build_verilated(["--binary", "--timing", "-CFLAGS", "-fcoroutines", "--timescale", "1ns/1ps",
                     "-O3", "-j", str(jobs), *(f"-D{d}" for d in defines),
                     "--top-module", "rast_uart_chain", *sorted(sources)],
                    bdir, "the load chain")
    return exe


def run_chain(system, sent, src_words, n_steps, work, *, tail=100_000) -> ChainResult:
    """Simulate ``system`` (a :class:`rast.gateware.top.ReplaySystem`, or a
    :class:`rast.sim.sdram_top.SDRAMSystemTop`: the host then starts once the
    SDRAM is initialised) receiving the host bytes ``sent`` (``(byte, idle bit
    times before)``) while input words ``src_words`` (repeated) stream in, for
    ``n_steps`` samples."""
    from amaranth.back import verilog
    from .sdram_top import SDRAMSystemTop
    work = Path(work)
    defines = (f"RAST_WRITE_STAGING={WRITE_STAGING}",)
    if isinstance(system, SDRAMSystemTop):
        sources, defines = system.verilog_sources("rast_system"), (*defines, "RAST_SDRAM")
    else:
        sources = {"rast_system.v": verilog.convert(system, name="rast_system", emit_src=False)}
    sources["rast_uart_chain.v"] = resources.files("rast.sim").joinpath("rast_uart_chain.v").read_text()
    exe = _build(sources, work, defines)
    run = work / "uart_chain-run"
    shutil.rmtree(run, ignore_errors=True)
    run.mkdir(parents=True)
    capture_from = max(0, n_steps - tail)
    (run / "cfg.hex").write_text("".join(f"{v:016x}\n" for v in (len(sent), len(src_words), system.divisor,
                                                                 n_steps, capture_from)))
    (run / "rx.hex").write_text("".join(f"{(gap << 8) | b:08x}\n" for b, gap in sent))
    (run / "src.hex").write_text("".join(f"{int(w):08x}\n" for w in src_words))
    r = subprocess.run([str(exe)], cwd=run, capture_output=True, text=True)
    if r.returncode != 0 or not (run / "summary.txt").exists():
        raise RuntimeError(f"chain simulation failed:\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    sums = {}
    for line in (run / "summary.txt").read_text().split("\n"):
        if line:
            key, value = line.split()
            sums[key] = int(value, 16) if key[:3] in ("s1_", "s2_") else int(value)
    writes = [tuple(int(v, 16) for v in line.split()) for line in (run / "writes.txt").read_text().split("\n") if line]
    tx = bytes(int(v, 16) for v in (run / "tx.txt").read_text().split())
    out = np.array([int(v, 16) for v in (run / "out.txt").read_text().split()], dtype=np.int64)
    oi, oq = unpack_iq(out)
    return ChainResult(sums["steps"], writes, tx, sums, np.stack([oi, oq], axis=1), capture_from)


def weighted_sums(y):
    """The RTL's position-weighted sums of ``y`` (signed ints), modulo 2**64."""
    v = np.asarray(y, dtype=np.int64).view(np.uint64)
    s1 = np.cumsum(v, dtype=np.uint64)
    return int(s1[-1]) if len(s1) else 0, int(np.sum(s1, dtype=np.uint64)) if len(s1) else 0


def burst_train(pri: int = 1000, burst: int = 200, amplitude: int = 12000, omega: float = 0.3):
    """One period of a pulse train for the chain's input (I, Q): a tone burst
    of ``burst`` samples every ``pri`` (10 us every 50 us at 20 MS/s)."""
    t = np.arange(pri)
    xi = np.where(t < burst, np.round(amplitude * np.cos(omega * t)), 0).astype(np.int64)
    xq = np.where(t < burst, np.round(amplitude * np.sin(omega * t)), 0).astype(np.int64)
    return xi, xq


def check_chain(rtl: ChainResult, board: ModelBoard, contract, xi, xq) -> np.ndarray:
    """Check a chain run against the conversation and the bit-exact model:
    the bridge answered what the protocol says, the bus saw exactly the writes
    the host sent, and every output sample equals the model's given the same
    writes at the same samples (position-weighted sums over all of them, and
    the captured tail sample by sample). ``xi``, ``xq``: the input period.
    Raises AssertionError naming what differs; returns the model's output (2, n)."""
    if rtl.tx != bytes(board.replies):
        raise AssertionError("the bridge's answers differ from the protocol's")
    if [(a, d) for _, a, d in rtl.writes] != board.applied:
        raise AssertionError("the bus saw other writes than the host sent")
    n_out = rtl.sums["outs"]
    y = np.stack(ReplayModel(contract).run_with_writes(np.resize(xi, n_out), np.resize(xq, n_out), rtl.writes))
    for lane, k in (("i", 0), ("q", 1)):
        if (rtl.sums[f"s1_{lane}"], rtl.sums[f"s2_{lane}"]) != weighted_sums(y[k]):
            raise AssertionError(f"output {lane.upper()} differs from the model somewhere in {n_out} samples")
    tail = y[:, rtl.tail_from:].T
    bad = np.nonzero((rtl.tail != tail).any(axis=1))[0]
    if bad.size:
        raise AssertionError(f"first differing output {rtl.tail_from + bad[0]}: {rtl.tail[bad[0]]} "
                             f"vs {tail[bad[0]]}")
    return y


#: Samples the chain waits for LiteDRAM's initialisation at most before the host's first byte.
SDRAM_INIT_STEPS = 40_000


@dataclass
class SDRAMLoadChain:
    rtl: ChainResult
    y: np.ndarray              # the model's output, (2, n)
    contract: object           # the system's ReplayContract
    loads: list                # per load: (first, last) step of its bus writes
    stream_words: list         # per load: stream words rast load sent
    live: list                 # per load: whether rast load loaded it live (no channel muted)


def sdram_load_chain(cfg, manifest_dirs, work, *, play_between: int = 20_000, play_after: int = 80_000,
                     tail: int = 60_000, verify_last: bool = False) -> SDRAMLoadChain:
    """``rast load`` of each folder of ``manifest_dirs`` in turn through the
    UART into the replay system of ``cfg`` (a :class:`rast.gateware.build.BuildConfig`
    with ``pool="sdram"``) on LiteDRAM's simulation core, a tone-burst train
    streaming in all the while; ``play_between`` samples between two loads
    (the earlier farm plays alone) and ``play_after`` after the last; with
    ``verify_last`` the last load is ``rast load --verify``'s (every stream
    read back out of the SDRAM, the host waiting the contract's bound before
    it polls: the bridge's answers then show whether the bound held). Checked
    with :func:`check_chain` (every output sample equal to the model's), the
    core initialised without error, no pool error; AssertionError otherwise."""
    from rast.gateware.sdram.generate import generate_core
    from rast.gateware.uart import MIN_DIVISOR
    from rast.load import load_manifest
    from rast.model.contract.fixedpoint import pack_iq
    from rast.model.contract.hostproto import HostBridge
    from .sdram_top import SDRAMSystemTop
    if cfg.pool != "sdram":
        raise ValueError(f"sdram_load_chain needs a build with pool='sdram', not {cfg.pool!r}")
    system = SDRAMSystemTop(generate_core(sim=True), cfg.clock_mhz * 1e6, divisor=MIN_DIVISOR, timeout=400,
                            **{k: v for k, v in cfg.replay_kwargs().items() if k != "pool"},
                            sample_rate_hz=round(cfg.sample_rate_mhz * 1e6))
    contract = system.system.replay.contract
    board = ModelBoard(ReplayModel(contract), divisor=system.divisor)
    bridge = HostBridge(board)

    def wait(seconds):                  # the host waits: the line idles
        board.idle(-(-round(seconds * cfg.clock_mhz * 1e6) // system.divisor))

    counts, words, live = [], [], []
    for k, d in enumerate(manifest_dirs):
        if k:
            board.idle(play_between * contract.slots // system.divisor)
        verify = verify_last and k == len(manifest_dirs) - 1
        res = load_manifest(bridge, d, verify=verify, wait=wait)          # rast load's own code
        words.append(res["stream_words"])
        live.append(res["live"])
        counts.append(len(board.applied))
    xi, xq = burst_train()
    n_steps = (SDRAM_INIT_STEPS + -(-host_clocks(board.sent, system.divisor) // contract.slots)
               + contract.refill_samples + play_after)
    rtl = run_chain(system, board.sent, pack_iq(xi, xq), n_steps, work, tail=tail)
    if not (rtl.sums["init_done"] and not rtl.sums["init_error"]):
        raise AssertionError(f"LiteDRAM's initialisation: done {rtl.sums['init_done']}, "
                             f"error {rtl.sums['init_error']}")
    if rtl.sums["init_step"] >= SDRAM_INIT_STEPS:
        raise AssertionError(f"LiteDRAM took {rtl.sums['init_step']} samples to initialise")
    if rtl.sums["pool_error"]:
        raise AssertionError("the SDRAM pool lost a request or a write (pool_error)")
    y = check_chain(rtl, board, contract, xi, xq)
    loads = [(rtl.writes[a][0], rtl.writes[b - 1][0]) for a, b in zip([0] + counts[:-1], counts)]
    return SDRAMLoadChain(rtl, y, contract, loads, words, live)


def main(argv=None) -> int:
    """``python -m rast.sim.uart_chain CONFIG [CONFIG ...] --out DIR``: stream
    each config (``rast stream``), then :func:`sdram_load_chain` of them in
    turn into ``rast build --sdram``'s system; prints what it checked."""
    import argparse
    import dataclasses
    import time
    from rast.cli import main as rast_main
    from rast.gateware.build import BuildConfig
    from rast.gateware.uart import MIN_DIVISOR
    p = argparse.ArgumentParser(prog="python -m rast.sim.uart_chain", description=main.__doc__)
    p.add_argument("configs", nargs="+", help="farm configs (TOML), loaded in this order")
    p.add_argument("--out", required=True, help="folder for the streams and the simulation")
    p.add_argument("--channels", type=int, default=BuildConfig().channels)
    p.add_argument("--between-ms", type=float, default=100.0, help="radar time between two loads")
    p.add_argument("--after-ms", type=float, default=100.0, help="radar time after the last load")
    args = p.parse_args(argv)
    cfg = dataclasses.replace(BuildConfig(pool="sdram"), channels=args.channels)
    out = Path(args.out)
    dirs = []
    for k, config in enumerate(args.configs):
        dirs.append(out / f"load{k}")
        if rast_main(["stream", config, "--out", str(dirs[-1])]) != 0:
            return 1
    per_ms = round(cfg.sample_rate_mhz * 1e3)
    t0 = time.monotonic()
    run = sdram_load_chain(cfg, dirs, out / "sim", play_between=round(args.between_ms * per_ms),
                           play_after=round(args.after_ms * per_ms))
    n = run.rtl.steps
    print(f"{cfg.channels} channels, pool in SDRAM ({run.contract.pool_words} words), UART at {MIN_DIVISOR} clocks per bit")
    for k, ((a, b), words, live) in enumerate(zip(run.loads, run.stream_words, run.live)):
        print(f"load {k}: {words} stream words, bus writes from sample {a} to {b} ({(b - a) / per_ms:.1f} ms), "
              f"{'live' if live else 'muted'}")
    print(f"{n} samples ({n / per_ms:.1f} ms of radar time, {n * run.contract.slots} clocks), LiteDRAM "
          f"initialised at sample {run.rtl.sums['init_step']}, no pool error; every output sample equal to "
          f"the model's; {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
