"""The simulated world: the hidden reef and the vehicles in it.

The hidden reef (`truth`), the scenario generators (`scenarios`), the COTS probability map
(`cotsmap`), and the simulated vehicle (`vehicle`: kinematics through currents, station
keeping) with its camera on the hidden reef (`camera`), which stand where a real vehicle and a
real camera would, behind the vehicle port (`fleet_bus.vehicle_port`).

It stands on `hfc_core` (the problem model) and `fleet_bus`; the planner never imports it, nor
does the agent's decision logic, so nothing simulated can leak into a plan or a decision
(`tests/test_architecture.py`).
"""
