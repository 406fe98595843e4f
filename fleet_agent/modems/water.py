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

from fleet_bus import keys
from fleet_bus.auth import BusAuth, seal, unseal
from fleet_bus.clock import Clock
from fleet_bus.link import TxTag
from fleet_bus.modem_port import WATER_SPEC, Received, ReportSink


class ZenohWater:
    """A `fleet_bus.modem_port.ModemPort` on the emulated water (module docstring)."""

    spec = WATER_SPEC

    def __init__(self, session: zenoh.Session, vid: str, sink: ReportSink, clock: Clock,
                 auth: BusAuth | None = None) -> None:
        self._auth, self._sink, self._clock = auth, sink, clock
        self._tx_key, rx_key = keys.tx_key(vid), keys.rx_key(vid)
        self._tx = session.declare_publisher(self._tx_key)

        def on_sample(sample: zenoh.Sample) -> None:
            frame = unseal(auth, rx_key, sample.payload.to_bytes())
            if frame is not None:
                self._sink(Received(frame, self._clock.now()))

        self._rx = session.declare_subscriber(rx_key, on_sample)

    def transmit(self, frames: Sequence[bytes], kind: str, sent_s: float | None = None) -> None:
        for frame in frames:
            self._tx.put(seal(self._auth, self._tx_key, frame),
                         attachment=TxTag(kind, sent_s).encode())

    def close(self) -> None:
        self._rx.undeclare()
