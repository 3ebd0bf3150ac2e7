"""A signal delayed by a chain of registers, the one helper the engine's
components share for it."""

from amaranth.hdl import Signal

__all__ = ["delayed"]


def delayed(m, sig, n, name, *, data=False):
    """``sig`` delayed by ``n`` clocks (registers ``{name}_d1`` ... ``_dn`` in
    ``m``'s sync domain); ``data``: registers that carry only data, not reset."""
    for k in range(n):
        nxt = Signal.like(sig, name=f"{name}_d{k + 1}", reset_less=data)
        m.d.sync += nxt.eq(sig)
        sig = nxt
    return sig
