"""Events as sentences: one wording for the dashboard's event log, ``report.md`` and the
terminal ("auv1 found an aggregation at (333 m, 412 m), priority 62.7", not the record's
fields).

A find's position is read from the event's detail (`telemetry.detail_position`) as the
report and the ground station read it; once the position is a field of its own the wording
stays and only `_position` changes.
"""

from __future__ import annotations

from typing import Callable, Sequence

from fleet_bus.telemetry import Event, detail_position, detail_stopped_s

LIST_AT_MOST = 6  # spot ids named in a sentence; the rest are counted
# How loud each kind is in a log (the dashboard's TextLog levels); unknown kinds are INFO.
LEVELS = {"abort": "WARN", "recall": "WARN", "lost": "WARN", "suspect": "WARN",
          "claim_lost": "WARN",
          "refused": "WARN", "takeover": "INFO", "revived": "INFO"}
# Kinds an operator reads after a mission (the terminal, report.md); the others (claims,
# clears, replans, inspections) are many and their sums are in the report's figures.
NOTABLE = ("abort", "suspect", "lost", "revived", "takeover", "claim_lost", "restart", "rejoined",
           "refused", "found", "order", "recall", "pause", "resume", "dropped", "added")


def spot_list(ids: Sequence[int], word: str = "spot") -> str:
    """``spot 4``, ``spots 4 and 7``, ``spots 1, 2, 3, 4, 5, 6 and 3 more``."""
    ids = list(ids)
    if not ids:
        return f"no {word}"
    if len(ids) == 1:
        return f"{word} {ids[0]}"
    shown = [str(i) for i in ids[:LIST_AT_MOST]]
    rest = len(ids) - len(shown)
    if rest:
        return f"{word}s {', '.join(shown)} and {rest} more"
    return f"{word}s {', '.join(shown[:-1])} and {shown[-1]}"


def where(pos: Sequence[float]) -> str:
    """``(333 m, 412 m)``: a position in the scenario's local metres (x east, y north)."""
    return f"({pos[0]:.0f} m, {pos[1]:.0f} m)"


def _position(e: Event) -> tuple[float, float, float] | None:
    return detail_position(e.detail)


def find_priority(detail: str) -> float | None:
    """The ``rho R`` of a find's detail (`fleet_agent.discovery`)."""
    words = detail.split()
    for a, b in zip(words, words[1:]):
        if a == "rho":
            try:
                return float(b)
            except ValueError:
                return None
    return None


def _found(e: Event) -> str:
    pos, rho = _position(e), find_priority(e.detail)
    return (f"{e.id} found an aggregation" + (f" at {where(pos)}" if pos is not None else "")
            + (f", priority {rho:g}" if rho is not None else "")
            + (f" (find {e.tasks[0]})" if len(e.tasks) == 1 else ""))


def _added(e: Event) -> str:
    pos, rho = _position(e), find_priority(e.detail)
    return (f"{e.id} added {spot_list(e.tasks)} on the operator's order"
            + (f" at {where(pos)}" if pos is not None else "")
            + (f", priority {rho:g}" if rho is not None else ""))


def _cleared(e: Event) -> str:
    pos = _position(e)
    if pos is not None and len(e.tasks) == 1:
        return f"{e.id} treated the aggregation found at {where(pos)} (find {e.tasks[0]})"
    return f"{e.id} treated {spot_list(e.tasks)}"


def _lost(e: Event) -> str:
    peer = e.peer or "a peer"
    if e.detail == "aborted":
        return f"{e.id} heard {peer}'s abort: {peer} is out of the mission"
    return f"{e.id} declared {peer} lost (silent, confirmed by another vehicle)"


def _replan(e: Event) -> str:
    if e.detail == "home":
        return f"{e.id} reached its rendezvous"
    return f"{e.id} changed its route" + (f" ({e.detail})" if e.detail else "")


def _detail(e: Event) -> str:
    return f" ({e.detail})" if e.detail else ""


def _judged_treated(e: Event) -> str:
    stopped_s = detail_stopped_s(e.detail)
    if stopped_s is not None:  # left mid-injection: a peer's clear of the spot heard
        return (f"{e.id} stopped injecting {spot_list(e.tasks)} after {stopped_s:.0f} s: "
                "another vehicle treated it")
    return (f"{e.id} skips {spot_list(e.tasks)}: someone already treated what is probably "
            "the same aggregation")


# One wording per kind of `fleet_bus.telemetry.EVENT_KINDS` (a test holds them equal).
_WORDS: dict[str, Callable[[Event], str]] = {
    "found": _found,
    "cleared": _cleared,
    "empty": lambda e: f"{e.id} found {spot_list(e.tasks)} empty",
    "inspected": lambda e: f"{e.id} saw COTS at {spot_list(e.tasks)}"
                           + (", too far for its battery to treat" if "beyond" in e.detail
                              else ""),
    "judged_treated": _judged_treated,
    "search": lambda e: f"{e.id} searches around {spot_list(e.tasks)}",
    "claim": lambda e: f"{e.id} claimed {spot_list(e.tasks)}",
    "claim_lost": lambda e: f"{e.id} gave up {spot_list(e.tasks)} to "
                            f"{e.peer or 'a peer'}'s earlier claim",
    "abort": lambda e: f"{e.id} aborted its mission{_detail(e)}",
    "suspect": lambda e: f"{e.id} has not heard {e.peer or 'a peer'} for a while and "
                         "suspects it is lost",
    "lost": _lost,
    "revived": lambda e: f"{e.id} heard {e.peer or 'a peer'} again after declaring it lost",
    "takeover": lambda e: f"{e.id} took over {spot_list(e.tasks)} from {e.peer or 'a peer'}",
    "replan": _replan,
    "restart": lambda e: f"{e.id}'s agent restarted from its journal{_detail(e)}",
    "rejoined": lambda e: f"{e.id} rejoined the fleet{_detail(e)}",
    "refused": lambda e: f"{e.id} refused a command" + (f": {e.detail}" if e.detail else ""),
    "navigation": lambda e: f"{e.id}'s navigation{_detail(e)}",
    "late": lambda e: f"{e.id} is late{_detail(e)}",
    "order": lambda e: (f"{e.id} {e.detail}" if e.detail.startswith("refused")
                        else f"{e.id} took the operator's order {e.detail}"),
    "recall": lambda e: f"{e.id} was recalled by the operator and heads home",
    "pause": lambda e: f"{e.id} keeps station: paused by the operator",
    "resume": lambda e: f"{e.id} goes on: resumed by the operator",
    "dropped": lambda e: f"{e.id} dropped {spot_list(e.tasks)} on the operator's order",
    "added": _added,
}
EVENT_WORDS = frozenset(_WORDS)


def sentence(e: Event) -> str:
    """One sentence (no final stop) saying what ``e`` means; a kind this version does not
    know is still said, with its fields."""
    words = _WORDS.get(e.kind)
    if words is not None:
        return words(e)
    text = f"{e.id} {e.kind}"
    if e.tasks:
        text += f" {spot_list(e.tasks)}"
    if e.peer:
        text += f" ({e.peer})"
    return text + (f": {e.detail}" if e.detail else "")


def level(e: Event) -> str:
    """The event's log level: WARN for what an operator must notice, else INFO."""
    return LEVELS.get(e.kind, "INFO")
