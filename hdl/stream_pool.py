"""The stream pool: one memory for every channel's stream, read by tagged fetches."""

from functools import reduce
from operator import or_

from amaranth.hdl import Module, Signal, Cat, Mux
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .ecp5_primitives import RegisteredRAM, kept_register, block_ram_rows, dp16kd_mode
from rast.model.contract.fixedpoint import STREAM_WIDTH, POOL_BANK_WORDS

__all__ = ["StreamPool"]


class StreamPool(wiring.Component):
    """``words`` stream words in block RAM: a write port for the host and a
    read port for fetches, each carrying a tag that comes back with its word.

    A fetch presented with ``r_valid`` comes back ``latency`` clocks later on
    ``d_valid``/``d_tag``/``d_data`` (every clock may carry one; nothing
    stalls). An address at or beyond ``words`` reads 0 and is not written.
    Pools deeper than POOL_BANK_WORDS are banks of that many words (on ECP5
    each a width-sliced, output-registered RAM) behind a registered
    multiplexer. This is the interface a second back end (external SDRAM)
    serves with a variable latency and ``r_ready``.

    Parameters
    ----------
    words : int
        Pool words: a power of two from 16 to POOL_BANK_WORDS, or a multiple
        of POOL_BANK_WORDS.
    tag_width : int
    init : sequence of int
        Power-up contents from address 0.
    reserve_sites : int
        Block-RAM sites per row kept together for another RAM where the
        banks are placed (:meth:`reserved_sites`).
    block_sites : int
        Where the banks are placed, the sites left in each row in blocks of
        this many neighbouring sites, each for one more RAM of that many
        block RAMs (:meth:`free_blocks`); 0: spread one by one.

    Members
    -------
    w_en : In(1), w_addr : In(address width), w_data : In(32)
    r_valid : In(1), r_addr : In(address width), r_tag : In(tag_width)
    d_valid : Out(1), d_tag : Out(tag_width), d_data : Out(32)
    """

    #: Block-RAM slices (bits) per kept copy of a bank's read and write access.
    GROUP_BITS = 8

    def __init__(self, words, tag_width, init=(), *, reserve_sites=0, block_sites=0):
        if not (isinstance(words, int) and not isinstance(words, bool) and 16 <= words
                and (words % POOL_BANK_WORDS == 0 if words > POOL_BANK_WORDS else not words & (words - 1))):
            raise ValueError(f"Pool words must be a power of two from 16 to {POOL_BANK_WORDS} or a "
                             f"multiple of {POOL_BANK_WORDS}, not {words!r}")
        if not isinstance(tag_width, int) or isinstance(tag_width, bool) or tag_width < 1:
            raise ValueError(f"Tag width must be a positive integer, not {tag_width!r}")
        init = [int(w) & ((1 << 2 * STREAM_WIDTH) - 1) for w in init]
        if len(init) > words:
            raise ValueError(f"Initial pool contents must have at most {words} words, not {len(init)}")
        if not isinstance(reserve_sites, int) or isinstance(reserve_sites, bool) or reserve_sites < 0:
            raise ValueError(f"Reserved sites must be a non-negative integer, not {reserve_sites!r}")
        if not isinstance(block_sites, int) or isinstance(block_sites, bool) or block_sites < 0:
            raise ValueError(f"Block sites must be a non-negative integer, not {block_sites!r}")
        self._words, self._init, self._reserve, self._block = words, init, reserve_sites, block_sites
        self._bank_words = min(words, POOL_BANK_WORDS)
        self._banks = words // self._bank_words
        aw = (words - 1).bit_length()
        super().__init__({
            "w_en": In(1), "w_addr": In(aw), "w_data": In(2 * STREAM_WIDTH),
            "r_valid": In(1), "r_addr": In(aw), "r_tag": In(tag_width),
            "d_valid": Out(1), "d_tag": Out(tag_width), "d_data": Out(2 * STREAM_WIDTH),
        })

    @property
    def latency(self):
        """Clocks from ``r_valid`` to ``d_valid``: one bank, the RAM's 3
        (address register, read, output register); several, 7 (the
        address's three register levels, read, output register, the group's
        data register, the bank multiplexer)."""
        return 3 if self._banks == 1 else 7

    def elaborate(self, platform):
        m = Module()
        L = self.latency
        valid = [self.r_valid] + [Signal(name=f"valid{k}") for k in range(1, L + 1)]
        tag = [self.r_tag] + [Signal.like(self.r_tag, name=f"tag{k}") for k in range(1, L + 1)]
        for k in range(1, L + 1):
            m.d.sync += [valid[k].eq(valid[k - 1]), tag[k].eq(tag[k - 1])]
        m.d.comb += [self.d_valid.eq(valid[L]), self.d_tag.eq(tag[L])]
        if self._banks == 1:
            m.submodules.bank0 = ram = RegisteredRAM(2 * STREAM_WIDTH, self._words, init=self._init,
                                                     addr_reg=True, continuous=True, output_reset=False)
            m.d.comb += [ram.w_en.eq(self.w_en), ram.w_addr.eq(self.w_addr), ram.w_data.eq(self.w_data),
                         ram.r_addr.eq(self.r_addr), self.d_data.eq(ram.r_data)]
            return m
        self._elaborate_banks(m, platform, valid)
        return m

    def _elaborate_banks(self, m, platform, valid):
        """Banks of width-sliced RAMs behind register trees.

        A bank's 32 slices of 16384 x 1 are spread over the block-RAM rows,
        and five banks fill most of the device's block RAMs. So nothing
        reaches them straight from one register: the read address and the
        write's enable, address and data go to a register per bank (the
        read address loaded only by a read of that bank, so that the copies
        differ and synthesis keeps them; the write's address and data
        kept), then to a kept copy per group of GROUP_BITS slices
        (:func:`kept_register`), each free to sit beside its group; the
        read address passes one more register, the RAM's own, so a write
        reaches the RAMs a clock before a read presented with it, as with
        one bank. A group's read data goes to a register of its own, zero
        unless the read was of its bank, and the word is the OR of the
        banks' groups.

        Where the device's block-RAM rows are known (:func:`block_ram_rows`)
        and a row has room for one group of every bank, the groups are
        placed: the groups of bits 8k..8k+7 of all banks in row k, in bank
        order, each group's slices in neighbouring sites, the sites left
        for the other RAMs spread evenly before, between and after them (a
        delay line then finds a block RAM near its logic anywhere along a
        row). A group's copies reach 8 sites in a row, and the OR of a byte
        over the banks stays in one row. ``reserve_sites`` sites of every
        row are kept together at the start of the middle gap for another
        RAM (the common delay line's: :meth:`reserved_sites`); with
        ``block_sites`` the sites left are blocks of neighbouring sites in
        gaps spread along the row (the windows': :meth:`free_blocks`)."""
        BW = self._bank_words
        bank_bits = (BW - 1).bit_length()
        r_bank, w_bank = self.r_addr[bank_bits:], self.w_addr[bank_bits:]
        # clocks from a read to its word at the groups' RAM outputs (bank
        # register, group copy, the RAM's address register, read, output
        # register); then the group's data register and the OR
        at = self.latency - 2
        floorplan = self._floorplan(platform)
        floorplan = floorplan and floorplan[0]
        # the read's bank along the pipeline: hit[k][b], "the read k clocks ago
        # was of bank b", to at - 1; the last clock's is a copy per group
        # (kept), beside the group's data register it clears: one register
        # per bank into its groups' four block-RAM rows was the default
        # build's latest path with router2 (hit5_bank2, 4.5 ns of one route)
        assert at >= 1
        hit = [[valid[0] & (r_bank == b) for b in range(self._banks)]]
        for k in range(1, at):
            hit.append([Signal(name=f"hit{k}_bank{b}") for b in range(self._banks)])
            m.d.sync += [h.eq(p) for h, p in zip(hit[k], hit[k - 1])]
        words = []
        for b in range(self._banks):
            ra = Signal(bank_bits, name=f"r_addr_bank{b}", reset_less=True)
            we = Signal(name=f"w_en_bank{b}")
            m.d.sync += we.eq(self.w_en & (w_bank == b))
            with m.If(hit[0][b]):
                m.d.sync += ra.eq(self.r_addr[:bank_bits])
            # the write's address and data every clock, kept per bank (under
            # the bank's hit, its compare into their enables was a latest
            # path of the 64-channel build, 6.8 ns)
            wa = kept_register(m, platform, self.w_addr[:bank_bits], f"w_addr_bank{b}")
            wd = kept_register(m, platform, self.w_data, f"w_data_bank{b}")
            word = []
            for gi, (g, gw) in enumerate(self._groups()):
                name = f"bank{b}_bits{g}"
                ram = RegisteredRAM(gw, BW, init=[(w >> g) & ((1 << gw) - 1)
                                                  for w in self._init[b * BW:(b + 1) * BW]],
                                    addr_reg=True, continuous=True, output_reset=False,
                                    sites=floorplan[gi][b] if floorplan else None)
                m.submodules[name] = ram
                m.d.comb += [ram.w_en.eq(kept_register(m, platform, we, f"{name}_w_en", reset=True)),
                             ram.w_addr.eq(kept_register(m, platform, wa, f"{name}_w_addr")),
                             ram.w_data.eq(kept_register(m, platform, wd[g:g + gw], f"{name}_w_data")),
                             ram.r_addr.eq(kept_register(m, platform, ra, f"{name}_r_addr"))]
                data = Signal(gw, name=f"{name}_data", reset_less=True)
                hit_here = kept_register(m, platform, hit[at - 1][b], f"{name}_hit", reset=True)
                m.d.sync += data.eq(Mux(hit_here, ram.r_data, 0))
                word.append(data)
            words.append(Cat(*word))
        m.d.sync += self.d_data.eq(reduce(or_, words))

    def _groups(self):
        """``(first bit, bits)`` of each group of GROUP_BITS slices of a word."""
        W = 2 * STREAM_WIDTH
        return [(g, min(self.GROUP_BITS, W - g)) for g in range(0, W, self.GROUP_BITS)]

    def reserved_sites(self, platform):
        """The ``reserve_sites`` sites of each block-RAM row kept for another
        RAM (rows top to bottom, each left to right), or ``None`` where the
        banks are not placed (:meth:`_floorplan`)."""
        plan = self._floorplan(platform)
        return plan and plan[1]

    def free_blocks(self, platform, count):
        """``count`` blocks of ``block_sites`` neighbouring free sites (fewer
        if there are not so many), taken from the rows in turn, and in each
        row spread evenly along it: RAMs placed in them in order spread over
        the chip, so that the logic around each can have a region of its
        own. (The first blocks of each row, all at its left end, put four of
        a 16-channel build's eight windows 50-70 columns from their
        pipelines' logic.) ``None`` where the banks are not placed or
        ``block_sites`` is 0."""
        plan = self._floorplan(platform)
        if not plan or not self._block:
            return None
        per_row = plan[2]
        taken = [0] * len(per_row)
        for _ in range(min(count, sum(map(len, per_row)))):
            r = min((r for r in range(len(per_row)) if taken[r] < len(per_row[r])),
                    key=lambda r: (taken[r], r))
            taken[r] += 1
        spread = [[row[int((i + 0.5) * len(row) / n)] for i in range(n)] for row, n in zip(per_row, taken)]
        return [row[j] for j in range(max(taken, default=0)) for row in spread if j < len(row)]

    def _floorplan(self, platform):
        """``(sites[group][bank], reserved[row], blocks[row][block])``: the
        bels of each group's slices (see :meth:`_elaborate_banks`), of each
        row's reserved block and of its blocks of ``block_sites``, or
        ``None`` where the device's rows are unknown or too few or too short
        for this pool (a single bank is never placed)."""
        rows = block_ram_rows(platform)
        if self._banks == 1 or rows is None:
            return None
        per_group = [dp16kd_mode(gw, self._bank_words)[1] for _, gw in self._groups()]
        B, R, K = self._banks, self._reserve, self._block
        if len(rows) < len(per_group) or any(B * n + R > len(r) for n, r in zip(per_group, rows)):
            return None
        plan, reserved, blocks = [], [], []
        mid = (B + 1) // 2
        for row, n in zip(rows, per_group):
            # B + 1 gaps before, between and after the groups: the reserved
            # block at the start of the middle gap (after bank mid - 1), the
            # blocks of K spread over the gaps, the single sites left spread
            free = len(row) - B * n - R
            k = free // K if K else 0
            single = free - k * K
            in_gap = [0] * (B + 1)
            for j in range(k):
                in_gap[min(B, int((j + 0.5) * (B + 1) / k))] += 1
            at, groups, row_blocks = 0, [], []
            for g in range(B + 1):
                if g == mid:
                    reserved.append(row[at:at + R])
                    at += R
                for _ in range(in_gap[g]):
                    row_blocks.append(row[at:at + K])
                    at += K
                at += single * (g + 1) // (B + 1) - single * g // (B + 1)
                if g < B:
                    groups.append(row[at:at + n])
                    at += n
            assert at == len(row)
            plan.append(groups)
            blocks.append(row_blocks)
        return plan, reserved, blocks
