"""comms_sim: the water. A seeded acoustic channel model and the Zenoh relay that applies it."""
