"""Chains of registers the engine's stages share: a signal delayed
(``delayed``), a long delay in distributed RAM (``ring_delay``), a value
cleared by a register's synchronous reset (``cleared``), a selection in
registered levels (``select_registered``)."""

from amaranth.hdl import Signal, Mux, Array
from amaranth.lib import data
from amaranth.lib.memory import Memory

from .ecp5_primitives import local_constant, lut_ram_depth

__all__ = ["delayed", "ring_delay", "cleared", "select_registered", "RAM_DELAY_MIN"]


def delayed(m, sig, n, name, *, data=False):
    """``sig`` delayed by ``n`` clocks (registers ``{name}_d1`` ... ``_dn`` in
    ``m``'s sync domain); ``data``: registers that carry only data, not reset."""
    for k in range(n):
        nxt = Signal.like(sig, name=f"{name}_d{k + 1}", reset_less=data)
        m.d.sync += nxt.eq(sig)
        sig = nxt
    return sig


#: Shortest delay kept in distributed RAM rather than in a chain of registers.
RAM_DELAY_MIN = 3


def ring_delay(m, sig, n, inits, name, *, input_reg=False, clear=None, platform=None):
    """``sig`` delayed by ``n`` clocks, as a chain of ``n`` registers whose
    power-up values are ``inits`` (the first register's first) would delay it.

    From RAM_DELAY_MIN clocks on the chain is a distributed RAM (written every
    clock at a running address, read ``n - 1`` clocks later) and one output
    register: the engine's state rings hold hundreds of bits per slot, and
    the flip-flops of the chain were most of a 64-channel build's.
    ``input_reg``: the chain's first register stays a register before the
    RAM, so that the logic computing ``sig`` ends at flip-flops the placer
    puts beside it rather than at the RAMs' write ports.
    ``clear``: where 1, the output is 0 in the next clock instead (the last
    register's synchronous reset), so that logic reading the output needs
    no multiplexer after its own arithmetic.
    ``platform``: on ECP5 the RAM's write enable is a flip-flop of its own
    (``local_constant``) and its depth at least a primitive's 16 words, so
    that none of its pins is on nextpnr's die-wide constant net.

    Returns ``(output, registers)``: the registers of a short chain (all of
    them but the input and output registers are in the RAM otherwise)."""
    layout = sig.shape()
    if n < RAM_DELAY_MIN:
        regs = []
        for k in range(n):
            nxt = Signal(layout, init=inits[k], name=f"{name}{k}")
            m.d.sync += nxt.eq(cleared(sig, clear if k == n - 1 else None))
            sig = nxt
            regs.append(nxt)
        return sig, regs
    if input_reg:
        first = Signal(layout, init=inits[0], name=f"{name}_in")
        m.d.sync += first.eq(sig)
        out, regs = ring_delay(m, first, n - 1, inits[1:], name, clear=clear, platform=platform)
        return out, [first, *regs]
    depth = lut_ram_depth(n)             # more than the n - 1 words in flight
    const = (lambda v: layout.const(v)) if isinstance(layout, data.Layout) else (lambda v: v)
    # the word read in clock k (k = 1 .. n-1 after reset) is what the chain's
    # end would show then: the power-up value of register n - k
    init = [const(inits[0]) for _ in range(depth)]
    for k in range(1, n):
        init[(k - n) % depth] = const(inits[n - k - 1])
    mem = Memory(shape=layout, depth=depth, init=init, attrs={"ram_style": "distributed"})
    m.submodules[name] = mem
    wp = mem.write_port()
    rp = mem.read_port(domain="comb")
    # the write and the read address, each a counter of its own (a register
    # into the RAMs' address pins, no subtraction on the way)
    ptr = Signal(range(depth), name=f"{name}_wptr")
    rptr = Signal(range(depth), init=(1 - n) % depth, name=f"{name}_rptr")
    m.d.sync += [ptr.eq(ptr + 1), rptr.eq(rptr + 1)]
    out = Signal(layout, init=inits[n - 1], name=f"{name}_out")
    m.d.comb += [wp.en.eq(local_constant(m, platform, 1, 1, f"{name}_we")), wp.addr.eq(ptr),
                 wp.data.eq(sig), rp.addr.eq(rptr)]
    m.d.sync += out.eq(cleared(rp.data, clear))
    return out, [out]


def cleared(value, clear):
    """``value``, or 0 where ``clear`` (no clear: ``value``)."""
    return value if clear is None else Mux(clear, 0, value)


def select_registered(m, words, sel, name):
    """``words[sel]`` one clock later, no register gathering more than four
    words: groups of four selected into registers of their own (a 4:1
    multiplexer is one slice per bit), and the returned selection among the
    (at most four) groups, for the caller's register. An 8:1 selection in one
    clock was the FIR's latest path at 64 channels (6.1 ns)."""
    assert len(words) <= 16
    if len(words) <= 4:
        return delayed(m, Array(words)[sel] if len(words) > 1 else words[0], 1, name, data=True)
    groups = [delayed(m, Array(words[g:g + 4])[sel[:2]], 1, f"{name}_group{g // 4}", data=True)
              for g in range(0, len(words), 4)]
    return Array(groups)[delayed(m, sel[2:], 1, f"{name}_gsel", data=True)]
