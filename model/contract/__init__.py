"""The replay block's contract, plain Python: fixed-point formats, rounding,
latencies and the schedule (``fixedpoint``), the register map and its
document, the power-up state, the bit-exact datapath model, the load plan
and the host protocol. The gateware and the model read it; it imports
nothing else of RAST."""
