"""The vehicles an agent can drive: each a `fleet_bus.vehicle_port.VehiclePort`.

- `sim`: the simulated vehicle of the simulated world (`reef_sim.vehicle`);
- `moos`: a MOOS-IvP helm (pHelmIvP behind a MOOSDB);
- `ros2`: a ROS 2 helm (nav_msgs/Odometry in, goals out).

Only the agent's process shell (`fleet_agent.node`) and the mission launcher choose one; the
agent's decision logic never imports this package.
"""
