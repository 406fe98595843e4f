"""Emulated WHOI Micro-Modems: one virtual modem per vehicle, on TCP, in the emulated water.

A host (the project's `fleet_agent.modems.micromodem` driver, WHOI's ``acomms``, Goby's
MMDriver, ros_acomms) talks NMEA (`fleet_bus.nmea`) to its modem as to a real one on a serial
line; every transmission crosses the same channel model as the Zenoh relay's
(`comms_sim.channel`, on a shared `comms_sim.water.Water`), and receptions come back as the
modem would report them, at the mission time the model settles them.

- `packet`: what a modem puts on the water (the channel's bytes, and the header as a tag);
- `modem`: `VirtualModem`, one modem's protocol (host sentences in, sentences out);
- `fleet`: `ModemFleet`, the modems of a scenario on one water (addresses, positions);
- `server`: `ModemServer`, the TCP ports (one selector thread for every modem);
- `run`: `run_water`, everything together until stopped (`cotsfleet water`).

docs/modems.md lists the sentences, the rates, and what is not emulated.
"""
