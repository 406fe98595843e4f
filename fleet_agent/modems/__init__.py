"""Modems the agent can talk through (`fleet_bus.modem_port.ModemPort` implementations).

- `water`: the emulated water over Zenoh (``--modem water``, the default in emulation);
- `micromodem`: a WHOI Micro-Modem over its NMEA interface, on a serial device or TCP (a real
  modem, or `cotsfleet water --face micromodem`); `link` its byte stream;
- `choice`: `ModemChoice`, what ``--modem`` and ``--modem-rate`` say.
"""
