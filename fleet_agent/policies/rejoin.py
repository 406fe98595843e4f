"""A restarted agent rejoins the fleet before it acts (issue 31, item 5).

An agent restarted on an empty journal (lost, or a vehicle joining late) or on a damaged one
does not know what it cleared after the last record it can read, nor what the fleet cleared
while it was down; one restarted on its whole journal knows the first, not the second (its
peers took over its spots meanwhile, and treated some). Flying its route at once would treat
some spots twice. So it keeps station (`Navigation.rejoining`) and claims nothing until it
has learned the fleet's cleared set: until a peer's pose carries a cleared-set digest equal
to its own (the peers push their whole set to a vehicle whose digest lags,
`policies.hearing`), or nobody is heard within `ALONE_CYCLES` TDMA cycles (there is no one
to learn from), or `GIVE_UP_CYCLES` pass (a lossy link: it goes on with what it learned).
What it treated before the loss is not claimed again: its own treatments come only from what
it can read, and the fleet's set marks them cleared.
"""

from __future__ import annotations

from fleet_agent.intents import Count, Intent, Tell
from fleet_agent.knowledge import Knowledge
from fleet_bus.states import EventKind

ALONE_CYCLES = 4  # no peer heard in this many cycles: nobody to learn from
GIVE_UP_CYCLES = 16  # peers heard, digests never agreed: go on with what was learned


class Rejoin:
    """Whether this agent is still learning the fleet's cleared set after a lost journal."""

    def __init__(self, why: str | None, now: float, cycle_s: float) -> None:
        """``why``: what was lost (None: nothing, the agent acts at once)."""
        self.why, self.since_s, self.cycle_s = why, float(now), float(cycle_s)

    @property
    def waiting(self) -> bool:
        return self.why is not None

    def check(self, know: Knowledge, now: float) -> list[Intent]:
        """Done once the fleet's set is learned (see the module docstring)."""
        if self.why is None:
            return []
        waited = now - self.since_s
        mine = know.cleared.digest()
        if any(d == mine for d in know.peer_digest.values()):
            how = "learned from the fleet"
        elif not know.peer_digest and waited >= ALONE_CYCLES * self.cycle_s:
            how = "no peer heard: going on alone"
        elif waited >= GIVE_UP_CYCLES * self.cycle_s:
            how = "peers never agreed: going on with what was learned"
        else:
            return []
        self.why = None
        know.touch()  # the route fitted again to what is now known cleared
        return [Tell(now, EventKind.REJOINED, detail=f"{len(know.cleared)} spots cleared, {how}, "
                     f"after {waited:.0f} s"), Count("rejoin_s", int(round(waited)))]
