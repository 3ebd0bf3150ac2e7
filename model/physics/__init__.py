"""The turbine and wind-farm physics (seed chapter 2): configs, the echo of a
turbine (point scatterers, wires, flashes, tower and shadow), range-extended
turbines, farms from layouts, recorded signatures, and the modulation streams
made of them. Imports the contract (stream formats), never the radar side."""
