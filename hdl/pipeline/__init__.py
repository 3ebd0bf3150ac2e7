"""The stages of a pipeline of the time-multiplexed engine
(:class:`rast.hdl.channel_pipeline.ChannelPipeline`), one component each,
in the order a visit passes them: the slot schedule and register read
(``schedule``), the per-slot state (``slot_state``), the word cache
(``word_cache``), the FIR's multiplier-accumulator (``fir_mac``), the
interpolator's last step (``interpolator``), the window (``window_tap``),
the product, gain and slot sum (``product``)."""
