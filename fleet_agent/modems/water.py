"""The emulated water over Zenoh as an agent's modem (``--modem water``, the default).

Frames go to ``fleet/tx/<id>`` (signed by this vehicle; the attachment says the relay's queue
class and, for a host that ran late, when the frame was sent on the mission clock); the relay
carries them through the channel model (`comms_sim.relay`) and puts what each receiver hears
on ``fleet/rx/<dst>``, signed by the relay. What arrives for this vehicle is handed to the
sink as `Received`, on Zenoh's thread: the sink must only enqueue (`fleet_agent.node.Inbox`).
"""

from __future__ import annotations

from typing import Sequence

import zenoh

from fleet_bus import topics
from fleet_bus.auth import BusAuth, unseal
from fleet_bus.clock import Clock
from fleet_bus.link import TxTag
from fleet_bus.modem_port import WATER_SPEC, Received, ReportSink
from fleet_bus.topics import Publisher


class ZenohWater:
    """A `fleet_bus.modem_port.ModemPort` on the emulated water (module docstring)."""

    spec = WATER_SPEC

    def __init__(self, session: zenoh.Session, vid: str, sink: ReportSink, clock: Clock,
                 auth: BusAuth | None = None) -> None:
        self._sink, self._clock = sink, clock
        self._tx = Publisher(session, topics.TX.of(vid), auth)
        rx = topics.RX.of(vid)

        def on_sample(sample: zenoh.Sample) -> None:
            payload = unseal(auth, rx.key, sample.payload.to_bytes())
            if payload is not None:
                self._sink(Received(rx.decode(payload), self._clock.now()))

        self._rx = session.declare_subscriber(rx.key, on_sample)

    def transmit(self, frames: Sequence[bytes], kind: str, sent_s: float | None = None) -> None:
        for frame in frames:
            self._tx.put(frame, attachment=TxTag(kind, sent_s).encode())

    def close(self) -> None:
        self._rx.undeclare()
