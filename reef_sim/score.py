"""The world's score of a mission: what the vehicles really treated, from the simulated
vehicles' own book (`reef_sim.vehicle.SimVehicle.treatments`), not from what they reported.

With exact navigation the report's reading of the telemetry (a predicted spot by its task, a
find by its logged position) names the same truth spots. With navigation error a find's
logged position is the finder's estimate, metres off the truth, and a vehicle sent to a spot
may inject bare seabed or a neighbouring aggregation: only the world knows, and this tally is
what a benchmark should score a drifting fleet by.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from reef_sim.truth import Reef
from reef_sim.vehicle import Treatment


def world_tally(reef: Reef, books: Mapping[str, Sequence[Treatment]]) -> dict[str, Any]:
    """Per truth spot, the injections that really treated it (``books``: vehicle id -> its
    vehicle's treatments, in time order): ``priority`` of the distinct spots treated,
    ``duplicates`` (injections of a spot already treated, by anyone), ``missed`` (injections
    that treated nothing: bare seabed), and the unmapped aggregations treated."""
    events = sorted(((t.t_s, vid, t) for vid, book in books.items() for t in book),
                    key=lambda e: (e[0], e[1]))
    treated: dict[int, str] = {}
    duplicates = missed = 0
    for _, vid, t in events:
        if t.spot is None:
            missed += 1
        elif t.spot in treated:
            duplicates += 1
        else:
            treated[t.spot] = vid
    unmapped = set(reef.unmapped())
    return {
        "injections": len(events),
        "spots_treated": len(treated),
        "priority": round(sum(reef.spots[i].priority for i in treated), 2),
        "duplicates": duplicates,
        "missed": missed,
        "unmapped_treated": len(set(treated) & unmapped),
        "by_vehicle": {vid: sorted(i for i, v in treated.items() if v == vid)
                       for vid in sorted(books)},
    }
