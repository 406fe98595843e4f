"""What a frame not yet proven its sender's may hold back: a vehicle waits on it, never acts.

A peer's frame is proven only when a later frame of the same sender discloses its key
(`fleet_bus.tesla`), so under loss a claim heard in time can be proven a cycle or more
after the claim settle (`Knowledge.settled_s`) has run out. Preset seed 2 at 30 % loss:
auv3 named a find at 3263 s and claimed it at 3285 s; auv1, beside it, named the same
aggregation at 3280 s and claimed it at 3302 s. auv3's claim was heard at 3290.7 s, but the
one frame of auv3's that could have disclosed its key in time (a pose discloses none) was
lost: it was proven at 3320.7 s, 0.2 s after auv1's claim had settled, and both vehicles
injected the aggregation.

So a vehicle at a spot whose claim has settled waits on, up to ``unproven_wait_cycles``
more, while a held frame says something that, proven, would take the spot from it (its
sender's next frame heard proves it, or shows it forged): a claim of it no later than ours;
at a find, a claim no later than ours of a find we have not heard of, by a vehicle whose
heard track passed near (its FOUND may be lost: `discovery.await_gaps`); or a FOUND of an
aggregation that may be this one (its finder holds it from the FOUND on, `Holdings.found`).
Nothing unproven is taken: forged frames cost at most that wait, at that one spot.
"""

from __future__ import annotations

from typing import Iterable

from fleet_agent.association import found, same_aggregation
from fleet_agent.knowledge import Knowledge, own_claim_s
from fleet_agent.policies.plausible import been_there
from fleet_agent.wire import Claim, Found, Message


def rival(know: Knowledge, held: Iterable[Message], task: int, now: float) -> bool:
    """Does a frame in ``held`` (unproven, `Provenance.unproven`) say what would take
    ``task``, claimed by this vehicle, from it (the module docstring)?"""
    since = own_claim_s(know, task)
    if not since:
        return False  # the initial plan's: no claim is earlier
    b = know.beliefs
    names = set(know.names(task))
    is_find = b.is_find_slot(task)
    here = b.find_estimate(b.finds[task]) if is_find and task in b.finds else None
    for msg in held:
        if msg.sender == know.index:
            continue
        if isinstance(msg, Claim) and msg.t_s <= since:
            if names.intersection(msg.tasks) or (is_find and any(
                    b.is_find_slot(t) and t not in b.finds for t in msg.tasks)
                    and (msg.sender not in know.tracks
                         or been_there(know, msg.sender, task, now))):
                return True
        elif isinstance(msg, Found) and here is not None and msg.slot not in b.finds:
            if same_aggregation(found(msg.pos, msg.sigma_m, b.params, msg.priority), here,
                                b.params):
                return True
    return False
