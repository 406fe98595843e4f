"""What an emulated Micro-Modem puts on the water.

The channel carries bytes whose length sets the airtime and the frame error model: a data
packet occupies the water as its frames padded to the rate's frame size (a Micro-Modem sends
whole frames), a minipacket (acknowledgement, ping, ping reply) as `MINI_BYTES`. Who sent it
to whom, the rate, the acknowledgement flag and the frames' real lengths ride beside it as
the channel's tag (`OnAir`), as the modem's own frame headers and cycle init would.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from comms_sim.config import PRESETS, ChannelConfig
from fleet_bus.nmea import RATES, Rate

DATA, ACK, PING, PONG = "data", "ack", "ping", "pong"
# A Micro-Modem minipacket carries 13 bits [Goby MMDriver: MINI_PACKET_SIZE 2 bytes].
MINI_BYTES = 2

# The channel preset of each emulated rate (`comms_sim.config.PRESETS`, sources there): its
# bit rate, preamble and receiver. Rates without a preset are not emulated.
RATE_PRESETS = {0: "micromodem_rate0", 1: "micromodem_psk1", 5: "micromodem_psk5"}


@dataclass(frozen=True)
class OnAir:
    """The tag of one transmission: ``kind`` (`DATA`, `ACK`, `PING`, `PONG`), modem
    addresses, the rate, the acknowledgement flag, the data frames, and for a ping reply
    when the ping it answers started (``ping_sent_s``) and how long it lasted."""

    kind: str
    src: int
    dest: int
    rate: int
    ack: bool = False
    frames: tuple[bytes, ...] = ()
    ping_sent_s: float = 0.0
    ping_airtime_s: float = 0.0

    def on_air(self, rate: Rate) -> bytes:
        """The bytes that occupy the water (their content is never read back)."""
        if self.kind != DATA:
            return bytes(MINI_BYTES)
        return b"".join(f.ljust(rate.frame_bytes, b"\0") for f in self.frames)


def emulated_rates() -> tuple[int, ...]:
    return tuple(sorted(RATE_PRESETS))


def channel_config(rate: int) -> ChannelConfig:
    """The channel for a water whose modems all use ``rate``: the rate's preset, with room
    for a full packet. Raises ValueError for a rate that is not emulated."""
    if rate not in RATE_PRESETS:
        raise ValueError(f"rate {rate} is not emulated; emulated rates: "
                         f"{', '.join(map(str, emulated_rates()))}")
    return replace(PRESETS[RATE_PRESETS[rate]], max_frame_bytes=RATES[rate].packet_bytes)
