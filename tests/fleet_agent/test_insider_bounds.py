"""What an insider (a vehicle's keys) cannot do any more: push a peer's replay high-water
mark to the end of time with one frame from the future, or date a claim after its frame so
that it wins every conflict (docs/wire.md, "What an insider can still do")."""

from __future__ import annotations

import hashlib
import hmac
import struct

import pytest

from comms_sim.config import ChannelConfig
from cotsfleet.mission.inprocess import InProcessBackend
from fleet_agent.config import AgentConfig
from fleet_agent.wire import (FLEET_MAC_BYTES, KEY_BYTES, MAX_LEAD_S, MAX_SEQ, Claim, Codec,
                              Digest, Kind, Pose,
                              WireError, sender_key)
from reef_sim.scenarios.field import paper_preset_doc
from hfc_core.formats.scenario import problem_from_dict

KEY = bytes(range(16))
LOSSLESS = ChannelConfig(range_d50_m=1e9, max_range_m=1e9)


def test_a_frame_from_the_future_is_dropped_and_does_not_silence_its_sender() -> None:
    problem = problem_from_dict(paper_preset_doc(5))
    backend = InProcessBackend(problem, AgentConfig(), seed=5, key=KEY, channel=LOSSLESS)
    backend.start(())
    insider = backend.fleet.codec  # the fleet's own keys: what a captured vehicle holds
    for t, lead in ((200.0, 10**6), (230.0, MAX_SEQ - 230), (260.0, MAX_LEAD_S + 5)):
        forged = insider.encode(Pose(1, int(t) + lead, (0.0, 0.0, 0.0), 0, "home",
                                     Digest(0, 0)))
        backend.inject("auv1", t, forged)
    backend.advance(900.0)
    auv1 = backend.seats["auv1"].agent
    assert auv1.counters.get("drop_future") == 3
    # auv2's genuine frames still get through: it is alive to auv1, and nothing said "home".
    assert auv1.know.members.status(1) == "alive"
    assert auv1.know.replay.high_water()[1] <= 900


def test_a_claim_dated_after_its_frame_is_refused() -> None:
    codec = Codec(KEY, "run", 3, 90)
    with pytest.raises(ValueError):
        codec.encode(Claim(0, 100, 101, (1, 2)))
    good = codec.encode(Claim(0, 100, 100, (1, 2)))
    # Same frame with the claim time moved past the seq and a valid fleet MAC (an insider's).
    data = bytearray(good[:-FLEET_MAC_BYTES])
    head = 7 + codec.code_bytes + KEY_BYTES
    data[head:head + 4] = struct.pack(">I", 10**6)
    forged = bytes(data) + hmac.new(sender_key(KEY, "run", 0), bytes(data),
                                    hashlib.sha256).digest()[:FLEET_MAC_BYTES]
    assert forged[0] & 0x0F == Kind.CLAIM
    with pytest.raises(WireError) as err:
        codec.decode(forged)
    assert err.value.reason == "malformed"
