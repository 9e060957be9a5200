"""Simulated platforms: JSBSim models with their flight controllers.

This package is the only one that imports JSBSim (in :mod:`aircraft.jsbsim_model`).
"""
