"""Membership in a large fleet: silence counts only where a frame was to be expected. A
suspect out of this vehicle's reach is never declared lost, a witness out of the suspect's
reach confirms nothing, a peer whose slot comes seldom may be silent longer, and a heard
window speaks first of the silences its sender is judging."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fleet_agent.membership import ALIVE, LOST, SUSPECT, Membership
from fleet_agent.wire import HEARD_NEVER, HEARD_WINDOW, Heard


@dataclass
class Line:
    """Vehicles on a line at fixed x (m); who hears whom: within ``range_m``."""

    x: dict[int, float]
    range_m: float = 1000.0
    speed_mps: float = 2.0

    def expects(self, listener: int, speaker: int, t_s: float, slack_s: float = 0.0) -> bool:
        return abs(self.x[listener] - self.x[speaker]) <= self.range_m + self.speed_mps * slack_s


@dataclass
class Turns:
    """A cycle of ``cycle_s``; vehicles in ``seldom`` speak every ``every`` cycles."""

    cycle: float
    seldom: frozenset[int] = frozenset()
    every: int = 3

    def cycle_s(self, t_s: float) -> float:
        return self.cycle

    def turn_s(self, v: int, t_s: float) -> float:
        return self.cycle * (self.every if v in self.seldom else 1)


def never(n: int, *peers: int) -> Heard:
    return Heard(0, tuple(HEARD_NEVER if v in peers else 0 for v in range(n)))


def member(me: int, x: dict[int, float], cycle: float = 10.0, **kw: object) -> Membership:
    return Membership(len(x), me, 4 * cycle, cycle, timing=Turns(cycle, **kw),
                      reach=Line(x))


def test_a_suspect_out_of_reach_stays_suspected_whatever_the_witnesses_say() -> None:
    x = {0: 0.0, 1: 5000.0, 2: 5500.0, 3: 5200.0}  # 1 is 5 km from us, 2 and 3 near it
    m = member(0, x)
    m.heard(1, 0.0, 0.5)  # long ago, near; its last frames reached us only relayed
    m.relayed(1, 10.0, 12.0)
    assert 1 in m.check(50.0)
    for w in (2, 3):
        assert m.confirm(w, never(4, 1), sent_s=55.0, now_s=56.0) == []
    assert m.status(1) == SUSPECT and m.alive(1)  # its claims still stand here


def test_a_vehicle_that_took_the_last_frame_itself_allows_a_turns_travel() -> None:
    """Where the suspect was believed when it fell silent is a turn's reckoning: at 100
    vehicles it put a neighbour 763 m away at 1021 m, and it never judged. A vehicle that
    took the last frame itself allows for the suspect's travel in that turn (here 10 s at
    2 m/s: 20 m); a witness must still be believed within reach."""
    x = {0: 0.0, 1: 1015.0, 2: 1300.0, 3: 5000.0}  # 1 just beyond our reach; 2 near it
    m = member(0, x)
    m.heard(1, 10.0, 10.5)  # its last frame: we heard it ourselves
    assert 1 in m.check(50.0)
    assert m.confirm(3, never(4, 1), sent_s=55.0, now_s=56.0) == []  # 3: far from it
    assert m.confirm(2, never(4, 1), sent_s=57.0, now_s=58.0) == [1]
    assert m.status(1) == LOST


def test_beyond_a_turns_travel_even_the_last_frame_taken_is_not_reach() -> None:
    x = {0: 0.0, 1: 1200.0, 2: 1300.0}  # 1 believed 200 m beyond our reach
    m = member(0, x)
    m.heard(1, 10.0, 10.5)  # heard once at long range (the water carries farther, by luck)
    assert 1 in m.check(50.0)
    assert m.confirm(2, never(3, 1), sent_s=57.0, now_s=58.0) == []
    assert m.status(1) == SUSPECT


def test_a_witness_out_of_the_suspects_reach_confirms_nothing() -> None:
    x = {0: 0.0, 1: 800.0, 2: 3000.0, 3: 400.0}  # 1 near us; 2 far from 1; 3 near 1
    m = member(0, x)
    m.heard(1, 0.0, 0.5)
    m.check(40.0)
    assert m.confirm(2, never(4, 1), sent_s=45.0, now_s=46.0) == []
    assert m.status(1) == SUSPECT
    assert m.confirm(3, never(4, 1), sent_s=47.0, now_s=48.0) == [1]
    assert m.status(1) == LOST


def test_a_peer_whose_slot_comes_seldom_may_be_silent_longer() -> None:
    x = {0: 0.0, 1: 100.0, 2: 200.0}
    m = member(0, x, seldom=frozenset({2}))
    m.heard(1, 10.0, 10.5)
    m.heard(2, 10.0, 10.5)
    assert m.check(50.0) == [1]  # 4 turns of 10 s
    assert m.check(100.0) == []  # vehicle 2 speaks every 30 s: 4 of its turns is 120 s
    assert m.next_deadline_s() == 130.0
    assert m.check(130.0) == [2]


def test_the_heard_window_speaks_first_of_the_silences_its_sender_judges() -> None:
    n = 40
    x = {v: 10_000.0 * v for v in range(n)}  # everyone far apart...
    x[33] = 300.0  # ...but vehicle 33, near vehicle 0
    m = member(0, x)
    for v in range(1, n):  # the far ones' last frames reached us relayed, 33's directly
        m.heard(v, 0.0 if v != 33 else 10.0, 0.5 if v != 33 else 10.5)
        m.relayed(v, 10.0, 10.5)
    m.check(60.0)  # everyone silent since 10 s: all suspected, only 33 within reach
    field = m.heard_field(61.0)
    assert field.offset == 33
    # 33: not heard within 4 periods (trailing "never" codes are left off the wire)
    assert not field.codes or field.codes[0] == HEARD_NEVER
    m.heard(33, 62.0, 62.5)
    assert m.status(33) == ALIVE
    # Nothing to judge within reach: the window rotates over the roster as before.
    assert m.heard_field(63.0).offset != 33 or n <= HEARD_WINDOW


def test_only_a_vehicle_that_heard_the_suspect_about_as_late_as_anyone_judges_it() -> None:
    """Believed near on old news while others heard it later elsewhere: not ours to judge."""
    x = {0: 0.0, 1: 500.0, 2: 300.0}
    m = member(0, x)
    m.heard(1, 0.0, 0.5)  # we heard it at 0 s...
    m.relayed(1, 30.0, 35.0)  # ...another vehicle at 30 s
    m.heard(2, 69.0, 69.5)
    assert m.check(70.0) == [1]
    assert m.confirm(2, never(3, 1), sent_s=72.0, now_s=73.0) == []
    assert m.status(1) == SUSPECT
    m.heard(1, 80.0, 80.5)  # heard again ourselves: ours to judge once more
    m.heard(2, 119.0, 119.5)
    assert m.check(120.0) == [1]
    assert m.confirm(2, never(3, 1), sent_s=122.0, now_s=123.0) == [1]


def test_the_doubted_peers_follow_every_change_of_status() -> None:
    """`suspects` and the heard window's lead come from the peers membership doubts, kept as
    statuses change rather than scanned from the roster: they agree with the roster at every
    step (suspected, revived, aborted, lost)."""
    n = 40
    x = {v: 100.0 * v for v in range(n)}  # all within reach of one another
    m = member(0, x)

    def scanned() -> list[int]:
        return [v for v in range(1, n) if m.status(v) == SUSPECT]

    for v in range(1, n):
        m.heard(v, 10.0, 10.5)
    m.check(60.0)  # all silent since 10 s
    assert m.suspects() == scanned() == list(range(1, n))
    m.heard(5, 61.0, 61.5)  # revived
    m.mark(7, "aborted", 62.0)  # announced its abort
    for w in (1, 2):  # two witnesses confirm 9's silence
        m.confirm(w, never(n, 9), 63.0, 63.5)
    assert m.status(9) == LOST and m.status(5) == ALIVE
    assert m.suspects() == scanned() and not {5, 7, 9} & set(m.suspects())
    assert m.heard_field(64.0).offset in m.suspects() + [9]


@dataclass
class Epochs:
    """Turns that lengthen at ``change_s`` (a spatial schedule's epochs): a deadline depends on
    when it is asked."""

    change_s: float = 200.0

    def cycle_s(self, t_s: float) -> float:
        return 10.0 if t_s < self.change_s else 25.0

    def turn_s(self, v: int, t_s: float) -> float:
        return self.cycle_s(t_s) * (1 + v % 2)


def test_the_next_deadline_is_always_the_earliest_silence_as_it_stands() -> None:
    """`next_deadline_s` corrects its queue's lower bounds lazily; after any mix of frames,
    relayed evidence, checks and announcements, with turns that lengthen mid-mission, it is
    still the earliest deadline of an alive peer computed afresh (a stale answer would wake
    the agent late or never)."""
    rng = np.random.default_rng(7)
    n = 6
    m = Membership(n, 0, 40.0, 10.0, timing=Epochs(), reach=Line({v: 0.0 for v in range(n)}))
    now = 0.0
    for _ in range(600):
        now += float(rng.exponential(4.0))
        v = int(rng.integers(1, n))
        what = rng.random()
        if what < 0.45:
            m.heard(v, now - float(rng.uniform(0.0, 3.0)), now)
        elif what < 0.6:
            m.relayed(v, now - float(rng.uniform(0.0, 30.0)), now)
        elif what < 0.62:
            m.mark(v, "aborted", now)
        else:
            m.check(now)
        alive = [u for u, p in m.peers.items() if p.status == ALIVE]
        expected = min((m._deadline(u, m._checked_s) for u in alive), default=None)
        assert m.next_deadline_s() == expected
        assert m.next_deadline_s() == expected  # asked again, nothing changed
