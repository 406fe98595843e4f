"""reef_sim: the simulated world: the hidden reef (`truth`), scenario generators
(`scenarios`), the COTS probability map (`cotsmap`), and the simulated vehicle and its camera.

It stands on `hfc_core` (the problem model) and `fleet_bus`; the planner never imports it, so
nothing simulated can leak into a plan (`tests/test_architecture.py`).
"""
