"""Modems the agent can talk through (`fleet_bus.modem_port.ModemPort` implementations).

- `micromodem`: a WHOI Micro-Modem over its NMEA interface, on a serial device or TCP (a real
  modem, or `cotsfleet water --face micromodem`).
"""
