"""The vehicles an agent can drive: each a `fleet_bus.vehicle_port.VehiclePort`.

- `sim`: the simulated vehicle of the simulated world (`reef_sim.vehicle`), with its camera on
  the hidden reef;
- `moos`: `MoosHelm`, a MOOS-IvP vehicle (its MOOSDB, pHelmIvP, NAV_*), through our own MOOS
  client (`moos_client`, `moos_wire`); `moos_mission` writes a vehicle's ``.moos`` and ``.bhv``;
- `ros2`: `Ros2Helm`, a ROS 2 vehicle (nav_msgs/Odometry in; goal, path and std_srvs services
  out; the interface in `ros2_iface`); `ros2_vehicle`: any `VehiclePort` served as such a ROS 2
  vehicle;
- `choice`: `HelmChoice` (``--helm`` and its options) and `open_vehicle`, the one factory;
  `sim.bridged_vehicle` is the simulated vehicle a ROS 2 bridge serves in a mission;
- `frames` (helm frames and headings), `camera` (the camera a helm consults, detections as
  text), `duty` (the command under way), `reports` (bounded reports, navigation figures).

Only the agent's process shells (`fleet_agent.node`, `fleet_agent.onboard`) and the mission
launcher choose one; the agent's decision logic never imports this package. rclpy is
optional (the ``ros2`` extra): only `ros2` and `ros2_vehicle` import it.
"""
