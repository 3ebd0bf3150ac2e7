"""LiteDRAM's SDR SDRAM controller for the ULX3S: generated at build time
(:mod:`.generate`), initialised without a CPU (:mod:`.init`), instanced from
Amaranth (:mod:`.core`). See docs/sdram.md."""
