"""The radar's side: sampled pulses for the cosimulations, the model radar
(receiver, spectrograms), spur-free dynamic range and the pictures. Imports
the physics and the contract."""
