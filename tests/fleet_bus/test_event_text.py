"""Events as sentences, one wording for the dashboard, report.md and the terminal."""

from __future__ import annotations

import pytest

from fleet_bus.event_text import EVENT_WORDS, level, sentence, spot_list
from fleet_bus.telemetry import (EVENT_KINDS, Event, detail_stopped_s, position_detail,
                                  stopped_detail)


def test_a_find_reads_as_a_sentence_not_a_record() -> None:
    e = Event(1200.0, "auv1", "found", [91],
              detail=f"{position_detail((333.4, 411.7, -15.8))} rho 62.7")
    assert sentence(e) == "auv1 found an aggregation at (333 m, 412 m), priority 62.7 (find 91)"


@pytest.mark.parametrize("event,text", [
    (Event(1, "auv1", "cleared", [12]), "auv1 treated spot 12"),
    (Event(1, "auv3", "cleared", [109], detail="443.8,797.1,-6.0"),
     "auv3 treated the aggregation found at (444 m, 797 m) (find 109)"),
    (Event(1, "auv2", "empty", [7]), "auv2 found spot 7 empty"),
    (Event(1, "auv2", "inspected", [7], detail="present"), "auv2 saw COTS at spot 7"),
    (Event(1, "auv2", "inspected", [7], detail="present, beyond the battery"),
     "auv2 saw COTS at spot 7, too far for its battery to treat"),
    (Event(1, "auv1", "claim", [4, 5, 9]), "auv1 claimed spots 4, 5 and 9"),
    (Event(1, "auv1", "claim_lost", [4], peer="auv2"),
     "auv1 gave up spot 4 to auv2's earlier claim"),
    (Event(1, "auv1", "judged_treated", [4, 5]),
     "auv1 skips spots 4 and 5: someone already treated what is probably the same aggregation"),
    (Event(1, "auv1", "judged_treated", [4], detail="stopped injecting after 41.6 s"),
     "auv1 stopped injecting spot 4 after 42 s: another vehicle treated it"),
    (Event(1, "auv2", "abort"), "auv2 aborted its mission"),
    (Event(1, "auv2", "abort", detail="no navigation for 130 s"),
     "auv2 aborted its mission (no navigation for 130 s)"),
    (Event(1, "auv1", "added", (163,), detail="512.0,589.0,-15.4 rho 80"),
     "auv1 added spot 163 on the operator's order at (512 m, 589 m), priority 80"),
    (Event(1, "auv1", "suspect", peer="auv2"),
     "auv1 has not heard auv2 for a while and suspects it is lost"),
    (Event(1, "auv1", "lost", peer="auv2", detail="silent"),
     "auv1 declared auv2 lost (silent, confirmed by another vehicle)"),
    (Event(1, "auv1", "lost", peer="auv2", detail="aborted"),
     "auv1 heard auv2's abort: auv2 is out of the mission"),
    (Event(1, "auv1", "revived", peer="auv2"), "auv1 heard auv2 again after declaring it lost"),
    (Event(1, "auv1", "takeover", [3, 4], peer="auv2"), "auv1 took over spots 3 and 4 from auv2"),
    (Event(1, "auv1", "replan", detail="home"), "auv1 reached its rendezvous"),
    (Event(1, "auv1", "replan", detail="cooperation"), "auv1 changed its route (cooperation)"),
    (Event(1, "auv3", "restart", detail="12 cleared"),
     "auv3's agent restarted from its journal (12 cleared)"),
    (Event(1, "auv1", "refused", detail="inject: busy"), "auv1 refused a command: inject: busy"),
    (Event(1, "auv1", "teleported", [1], peer="x", detail="why"),
     "auv1 teleported spot 1 (x): why"),
])
def test_each_kind_has_its_sentence(event: Event, text: str) -> None:
    assert sentence(event) == text


def test_every_kind_the_agent_reports_is_worded() -> None:
    """A kind added to the telemetry without a wording here fails this test."""
    assert set(EVENT_KINDS) <= set(EVENT_WORDS)


def test_long_lists_are_counted_and_levels_follow_the_kind() -> None:
    assert spot_list(list(range(1, 11))) == "spots 1, 2, 3, 4, 5, 6 and 4 more"
    assert spot_list([]) == "no spot"
    assert level(Event(1, "a", "lost", peer="b")) == "WARN"
    assert level(Event(1, "a", "cleared", [1])) == "INFO"


def test_a_stopped_injection_detail_round_trips_and_nothing_else_reads_as_one() -> None:
    """A claim-lost or judged-treated event's "stopped injecting after N s" (the timeline's
    injecting time)."""
    assert detail_stopped_s(stopped_detail(42.34)) == 42.3
    assert detail_stopped_s(stopped_detail(-1.0)) == 0.0
    for other in ("", "stopped injecting after", "stopped injecting after nan s",
                  "stopped injecting after inf s", "stopped injecting after x s", "12.0 s"):
        assert detail_stopped_s(other) is None
