"""The maps of `benchmarks.search_value`: one that knows every missed aggregation, one without
the empty predicted spots, and the fates of the missed aggregations from the simulator's books."""

from __future__ import annotations

import copy
from types import SimpleNamespace

import numpy as np

from benchmarks.dynamic import SETTINGS
from benchmarks.search_value import FATES, fates, knowing_unmapped, without_empty
from hfc_core.formats.scenario import problem_from_dict
from reef_sim.scenarios.dynamic import generate_dynamic_doc
from reef_sim.truth import reef_from_doc


def _doc() -> dict:
    return generate_dynamic_doc(SETTINGS["hard"], np.random.default_rng(3))


def _reef(doc: dict):
    problem = problem_from_dict(doc)
    return problem, reef_from_doc(doc, problem)


def test_the_search_map_names_every_missed_aggregation_as_it_really_is():
    doc = _doc()
    before = copy.deepcopy(doc)
    _, reef = _reef(doc)
    missed = [reef.spots[i] for i in reef.unmapped()]
    assert missed  # the hard setting misses 41
    known = knowing_unmapped(doc)
    assert doc == before  # the generator's doc is left as it was
    problem, reef2 = _reef(known)
    assert reef2.unmapped() == []
    assert problem.n_tasks == len(doc["tasks"]) + len(missed)
    assert len({t["id"] for t in known["tasks"]}) == len(known["tasks"])
    for s in missed:  # each at its true place, with its rho and injection time
        i = next(j for j, t in enumerate(problem.tasks) if tuple(t.pos) == tuple(s.pos))
        assert problem.tasks[i].priority == s.priority
        assert problem.tasks[i].service_s == s.service_s
        assert reef2.spots[reef2.of_task(i)].pos == s.pos
    # the empty predicted spots are still on it
    assert reef2.empty(problem.n_tasks) == reef.empty(len(doc["tasks"]))


def test_the_perfect_map_has_only_spots_that_hold_cots_and_keeps_the_truth_aligned():
    doc = knowing_unmapped(_doc())
    _, reef = _reef(doc)
    empty = reef.empty(len(doc["tasks"]))
    assert empty
    problem, reef2 = _reef(without_empty(doc))
    assert problem.n_tasks == len(doc["tasks"]) - len(empty)
    assert reef2.empty(problem.n_tasks) == [] and reef2.unmapped() == []
    for t in range(problem.n_tasks):  # each task still names the aggregation at its place
        spot = reef2.spots[reef2.of_task(t)]  # (the generator's map is exact: the same place)
        assert np.allclose(spot.pos[:2], problem.tasks[t].pos[:2], atol=0.01)
    assert sorted(s.pos for s in reef2.spots) == sorted(s.pos for s in reef.spots)


def test_fates_sort_each_missed_aggregation_by_the_books():
    _, reef = _reef(_doc())
    a, b, c, d, e = reef.unmapped()[:5]
    passes = np.zeros(len(reef.spots), dtype=np.int64)
    passes[[a, b, c, d]] = 1
    vehicles = {
        "auv1": SimpleNamespace(camera=SimpleNamespace(passes=lambda: passes),
                                sighted={b: 100.0, c: 3000.0}),
        "auv2": SimpleNamespace(camera=None, sighted={c: 500.0}),  # seen earlier by another
    }
    out = fates(reef, vehicles, treated={a}, late_s=2400.0)
    assert set(out) == set(FATES)
    prio = lambda i: float(reef.spots[i].priority)  # noqa: E731
    assert out["treated"] == [prio(a)]
    assert sorted(out["seen early"]) == sorted([prio(b), prio(c)])
    assert out["seen late"] == []
    assert out["passed, unseen"] == [prio(d)]
    assert prio(e) in out["never in reach"]
    assert sum(len(v) for v in out.values()) == len(reef.unmapped())
