"""The bus contract every cotsfleet process stands on.

Key expressions and their parsing (`keys`), the typed messages with validating decoders
(`telemetry`, `link`, `commands`, `mission`), the mission clock (`clock`), Zenoh session
configuration (`session`), the TDMA slot arithmetic the fleet and the water share (`tdma`),
and process plumbing: signals, parent watch and ready lines (`process`).

The rule of the tree: `fleet_agent`, `comms_sim` and `ground_station` are peers. Each imports
`fleet_bus` and `hfc_core`, never another peer; `cotsfleet` (the command line, the launcher
and the mission runner) wires them together. `fleet_bus` itself imports none of them
(`docs/architecture.md`; enforced by `tests/test_architecture.py`).
"""
