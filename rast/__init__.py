"""RAST: RAdar Simulation of wind Turbines."""
