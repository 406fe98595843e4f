"""The modem port: what passes between an agent and the acoustic modem it talks through.

The agent hands its modem the frames of one transmission (its TDMA slot) and learns from the
modem's reports what it heard (`Received`), what went out (`Sent`) and what the modem could
not send (`Dropped`). A modem declares what it carries (`ModemSpec`): the agent's wire codec
takes its frame budget from there, never from a constant.

Implementations (each a `ModemPort`):

- the emulated water over Zenoh (`fleet_agent.modems.water`): frames to ``fleet/tx/<id>``,
  the relay's channel model, deliveries from ``fleet/rx/<id>``;
- the emulated water in process (`cotsfleet.mission.inprocess`, on `comms_sim.des`);
- a WHOI Micro-Modem over its NMEA interface (`fleet_agent.modems.micromodem`), on a serial
  device or a TCP socket (a real modem, or `cotsfleet water --face micromodem`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol, Sequence, Union


@dataclass(frozen=True)
class ModemSpec:
    """What a modem carries: its largest frame, how many frames one transmission holds, its
    bit rate, whether it cannot hear while it sends, and whether it reports acknowledgements."""

    name: str
    max_frame_bytes: int
    bit_rate_bps: float
    frames_per_packet: int = 1
    half_duplex: bool = True
    acknowledged: bool = False

    def __post_init__(self) -> None:
        if not (isinstance(self.max_frame_bytes, int) and self.max_frame_bytes >= 1):
            raise ValueError(f"modem {self.name}: max_frame_bytes must be >= 1")
        if not (isinstance(self.frames_per_packet, int) and self.frames_per_packet >= 1):
            raise ValueError(f"modem {self.name}: frames_per_packet must be >= 1")
        if not self.bit_rate_bps > 0:
            raise ValueError(f"modem {self.name}: bit_rate_bps must be > 0")

    def airtime_s(self, n_bytes: int) -> float:
        """Seconds on the air for ``n_bytes`` of payload at the modem's bit rate."""
        return 8.0 * n_bytes / self.bit_rate_bps


# The emulated water's modem: one 64-byte frame per transmission at about 1 kbps (the default
# channel, `comms_sim.config`), the budget the v2 wire protocol was designed for.
WATER_SPEC = ModemSpec("water", max_frame_bytes=64, bit_rate_bps=1000.0)


@dataclass(frozen=True)
class Received:
    """A frame the modem decoded, at mission time ``t_s`` (the end of its reception)."""

    frame: bytes
    t_s: float


@dataclass(frozen=True)
class Sent:
    """A transmission of ``n_frames`` frames (``n_bytes`` in all) went out at ``t_s``."""

    t_s: float
    n_frames: int
    n_bytes: int


@dataclass(frozen=True)
class Dropped:
    """The modem could not send ``n_frames`` frames at ``t_s`` (``reason``: e.g. ``"busy"``,
    ``"error"``, ``"timeout"``, ``"oversize"``, ``"no_modem"``)."""

    t_s: float
    reason: str
    n_frames: int = 1


@dataclass(frozen=True)
class Acked:
    """The modem's acknowledgement of frame ``frame_no`` of the transmission at ``t_s``."""

    t_s: float
    frame_no: int


ModemReport = Union[Received, Sent, Dropped, Acked]
ReportSink = Callable[[ModemReport], None]


class ModemPort(Protocol):
    """A modem an agent can talk through (see the module docstring). Reports reach the sink
    the implementation was given, from whatever thread it reads its modem on."""

    spec: ModemSpec

    def transmit(self, frames: Sequence[bytes], kind: str, sent_s: float | None = None) -> None:
        """Send ``frames`` (at most ``spec.frames_per_packet``, each at most
        ``spec.max_frame_bytes``) as one transmission. ``kind``: ``"pose"`` if a newer pose
        may supersede it in the modem's queue, else ``"data"``; ``sent_s``: when the vehicle
        sends it on the mission clock, if its host ran late (`fleet_bus.link.TxTag`)."""

    def close(self) -> None:
        """Release the modem (idempotent)."""
