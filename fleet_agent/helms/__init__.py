"""Helms: the vehicle port (`fleet_bus.vehicle_port`) on vehicles that are not the project's.

- `moos`: `MoosHelm`, a MOOS-IvP vehicle (its MOOSDB, pHelmIvP, NAV_*), through our own
  MOOS client (`moos_client`, `moos_wire`); `moos_mission` writes a vehicle's ``.moos`` and
  ``.bhv``.
- `ros2`: `Ros2Helm`, a ROS 2 vehicle (nav_msgs/Odometry in; goal, path and std_srvs
  services out; the interface in `ros2_iface`); `ros2_vehicle`: any `VehiclePort` served as
  such a ROS 2 vehicle.
- `frames` (helm frames and headings), `camera` (the camera a helm consults, detections as
  text), `duty` (the command under way), `reports` (bounded reports, navigation figures).

rclpy is optional (the ``ros2`` extra): only `ros2` and `ros2_vehicle` import it.
"""
