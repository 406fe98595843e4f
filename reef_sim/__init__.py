"""The simulated world: the hidden reef and the vehicles in it.

Nothing here is the agent's: the simulated vehicle (`reef_sim.vehicle`: kinematics through
currents, a navigation estimate that may drift, station keeping) and its camera on the hidden
reef (`reef_sim.camera`) stand where a real vehicle and a real camera would, behind the
vehicle port (`fleet_bus.vehicle_port`). The planner never imports this package, and neither
does the agent's decision logic.
"""
