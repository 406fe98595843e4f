"""Matching under uncertainty (`fleet_agent.association`): named cases from the issue and the
example reef, and properties searched by Hypothesis."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_agent.association import (AssociationParams, Estimate, aliases, assign, chi2_gate,
                                     chi2_gate_1,
                                     distance2, fuse, match, posteriors, predicted,
                                     probably_treated, resolve, same_aggregation, sighting)

REPO = Path(__file__).resolve().parents[2]
P = AssociationParams()


def drifted(pos, run_m: float, drift_pct: float = 1.0) -> Estimate:
    """A sighting by a vehicle that ran ``run_m`` metres on dead reckoning at ``drift_pct``."""
    return sighting(pos, drift_pct / 100.0 * run_m, P)


# -- named cases ------------------------------------------------------------------------------


def test_the_gate_is_the_chi_square_quantile_of_two_degrees_of_freedom():
    assert chi2_gate(0.99) == pytest.approx(9.2103, abs=1e-4)
    assert chi2_gate(0.999) == pytest.approx(13.8155, abs=1e-4)


def test_two_vehicles_estimates_of_one_aggregation_8_m_apart_merge():
    a = drifted((100.0, 200.0), 300.0)
    b = drifted((108.0, 200.0), 250.0)
    assert same_aggregation(a, b, P) and same_aggregation(b, a, P)
    assert match(b, [("find-7", a)], P) == "find-7"


def test_two_real_aggregations_40_m_apart_stay_two():
    a = drifted((100.0, 200.0), 300.0)
    b = drifted((100.0, 240.0), 400.0)
    assert not same_aggregation(a, b, P)
    assert match(b, [("find-7", a)], P) is None


def test_an_aggregation_7_4_m_from_its_predicted_spot_is_that_spot():
    # Green Island's first aggregation: 7.4 m from predicted spot 0, exact navigation
    spot = predicted((0.0, 0.0), P)
    seen = sighting((7.4, 0.0), 0.0, P)
    assert match(seen, [(0, spot), ("find", sighting((60.0, 0.0), 2.0, P))], P) == 0


def test_green_island_every_mapped_aggregation_is_a_predicted_spot_never_new():
    doc = json.loads((REPO / "examples" / "green_island.json").read_text())
    tasks = [predicted(t["pos"], P) for t in doc["tasks"]]
    named = [s for s in doc["truth"]["spots"] if s["task"] is not None]
    assert named
    for s in named:
        seen = sighting(s["pos"], 0.0, P)
        got = match(seen, list(enumerate(tasks)), P)
        assert got is not None  # never taken for a new aggregation
        # it is its own spot once the spots a look showed empty are out of the running
        empty = set(range(len(tasks))) - {x["task"] for x in named}
        live = [(i, t) for i, t in enumerate(tasks) if i not in empty]
        assert match(seen, live, P) == s["task"]
        # and whichever spot it matched, treating it makes the other "probably treated"
        own = tasks[s["task"]]
        assert probably_treated(own, [tasks[got]], P)
    unmapped = [s for s in doc["truth"]["spots"] if s["task"] is None]
    far = [s for s in unmapped
           if min(math.dist(s["pos"][:2], t.xy) for t in tasks) > 30.0]
    for s in far:  # the aggregations the map missed far from any spot are new
        assert match(sighting(s["pos"], 0.0, P), list(enumerate(tasks)), P) is None


def test_between_two_predicted_spots_alike_only_a_look_can_tell():
    # Green Island's first aggregation: 7.4 m from its spot (task 0), 6.6 m from an empty one
    seen = sighting((0.0, 0.0), 0.0, P)
    own, empty = predicted((7.4, 0.0), P), predicted((-6.6, 0.0), P)
    key, sure = resolve(seen, [(0, own), (3, empty)], P)
    assert key == 3 and not sure  # nearest, but not nearer by enough to be taken for it
    probs = dict(posteriors(seen, [(0, own), (3, empty)], P))
    assert probs[3] + probs[0] == pytest.approx(1.0) and 0.5 < probs[3] < P.sure_p
    # on a generated map the aggregation is at its spot: the next one 10 m off is no rival
    key, sure = resolve(seen, [(0, predicted((0.0, 0.0), P)), (1, predicted((10.0, 0.0), P))],
                        P)
    assert (key, sure) == (0, True)
    assert resolve(seen, [(0, predicted((90.0, 0.0), P))], P) == (None, True)


def test_a_treated_aggregation_seen_again_by_another_vehicle_is_not_treated_again():
    treated_by_auv3 = drifted((412.0, 230.0), 600.0)  # its estimate when it injected
    seen_by_auv1 = drifted((421.0, 236.0), 900.0)  # the same aggregation, 11 m off
    assert probably_treated(seen_by_auv1, [treated_by_auv3], P)
    elsewhere = drifted((470.0, 236.0), 900.0)
    assert not probably_treated(elsewhere, [treated_by_auv3], P)
    assert not probably_treated(elsewhere, [], P)


def test_the_treated_gate_is_looser_than_the_matching_gate():
    a, b = sighting((0.0, 0.0), 2.0, P), sighting((0.0, 0.0), 2.0, P)
    d = math.sqrt((P.gate + P.treated_gate) / 2 * (8.0 + P.extent_var))  # between the gates
    b = sighting((d, 0.0), 2.0, P)
    assert not same_aggregation(a, b, P) and probably_treated(b, [a], P)


def test_a_vague_candidate_does_not_win_by_its_vagueness():
    seen = sighting((0.0, 0.0), 1.0, P)
    sharp = Estimate((6.0, 0.0), 1.0)
    vague = Estimate((9.0, 0.0), 40.0)  # a find whose finder had drifted far
    assert distance2(seen, vague, P) < distance2(seen, sharp, P)  # Mahalanobis alone...
    assert match(seen, [("vague", vague), ("sharp", sharp)], P) == "sharp"  # ...would not do


def test_assign_gives_each_candidate_to_one_sighting_globally():
    cands = [("a", sighting((0.0, 0.0), 1.0, P)), ("b", sighting((10.0, 0.0), 1.0, P))]
    seen = [sighting((4.0, 0.0), 1.0, P), sighting((-5.0, 0.0), 1.0, P)]
    # one by one, the first sighting would take its nearest, "a", and leave the second
    # (15 m from "b": outside the gate) a new aggregation; together both are matched
    assert [match(s, cands, P) for s in seen] == ["a", "a"]
    assert assign(seen, cands, P) == ["b", "a"]
    crowd = [sighting((0.5, 0.0), 1.0, P), sighting((-0.5, 0.0), 1.0, P)]
    assert sorted(assign(crowd, cands[:1], P), key=str) == [None, "a"]
    assert assign([], cands, P) == [] and assign(seen, [], P) == [None, None]


def test_fusing_two_looks_weights_the_surer_one():
    a, b = Estimate((0.0, 0.0), 1.0), Estimate((10.0, 0.0), 3.0)
    f = fuse(a, b)
    assert f.xy == pytest.approx((1.0, 0.0))
    assert f.sigma_m == pytest.approx(math.sqrt(9 / 10))


@pytest.mark.parametrize("bad", [dict(gate_p=1.0), dict(treated_gate_p=0.0),
                                 dict(extent_m=-1.0), dict(map_sigma_m=math.nan)])
def test_bad_parameters_are_refused(bad):
    with pytest.raises(ValueError):
        AssociationParams(**bad)


def test_bad_estimates_are_refused():
    with pytest.raises(ValueError):
        Estimate((math.nan, 0.0), 1.0)
    with pytest.raises(ValueError):
        Estimate((0.0, 0.0), -1.0)


# -- properties -------------------------------------------------------------------------------

coord = st.floats(-2000.0, 2000.0, allow_nan=False)
sigma = st.floats(0.0, 50.0, allow_nan=False)
estimates = st.builds(lambda x, y, s: Estimate((x, y), s), coord, coord, sigma)


@given(estimates, estimates)
def test_one_aggregation_or_two_does_not_depend_on_the_order(a, b):
    assert same_aggregation(a, b, P) == same_aggregation(b, a, P)
    assert distance2(a, b, P) == pytest.approx(distance2(b, a, P))


@given(estimates, st.floats(0.0, 50.0), st.floats(0.0, 3000.0), st.floats(0.0, 6.283))
def test_more_uncertainty_never_splits_and_farther_never_merges(a, more, d, theta):
    b = Estimate((a.xy[0] + d * math.cos(theta), a.xy[1] + d * math.sin(theta)), a.sigma_m)
    vaguer = Estimate(b.pos, math.hypot(b.sigma_m, more))
    if same_aggregation(a, b, P):
        assert same_aggregation(a, vaguer, P)
    farther = Estimate((a.xy[0] + 2 * d * math.cos(theta), a.xy[1] + 2 * d * math.sin(theta)),
                       a.sigma_m)
    if same_aggregation(a, farther, P):
        assert same_aggregation(a, b, P)
    assert same_aggregation(a, Estimate(a.pos, a.sigma_m), P)  # itself


@settings(max_examples=60)
@given(st.lists(estimates, max_size=6), st.lists(estimates, max_size=6))
def test_assign_is_a_matching_inside_the_gate_of_largest_size(seen, cands):
    keyed = list(enumerate(cands))
    got = assign(seen, keyed, P)
    taken = [k for k in got if k is not None]
    assert len(taken) == len(set(taken))  # each candidate to one sighting at most
    for s, k in zip(seen, got):
        if k is not None:
            assert same_aggregation(s, cands[k], P)
    # no unmatched sighting could take a candidate left free
    free = set(range(len(cands))) - set(taken)
    for s, k in zip(seen, got):
        if k is None:
            assert not any(same_aggregation(s, cands[j], P) for j in free)


@given(estimates, st.lists(estimates, max_size=8))
def test_match_is_inside_the_gate_and_treated_is_a_looser_gate(seen, cands):
    got = match(seen, list(enumerate(cands)), P)
    if got is None:
        assert not any(same_aggregation(seen, c, P) for c in cands)
    else:
        assert same_aggregation(seen, cands[got], P)
        assert probably_treated(seen, cands, P)


@given(estimates, estimates)
def test_fusion_is_between_and_surer_than_either(a, b):
    f = fuse(a, b)
    assert f.sigma_m <= min(a.sigma_m, b.sigma_m) + 1e-9
    for i in (0, 1):
        lo, hi = sorted((a.xy[i], b.xy[i]))
        assert lo - 1e-6 <= f.xy[i] <= hi + 1e-6


def test_drifting_vehicles_estimates_of_one_aggregation_merge_at_the_gate_rate():
    """Simulated: two vehicles see one aggregation (a disc of radius extent_m) with 1 %
    drift over 100-800 m each; about gate_p of the pairs merge (the gate is calibrated)."""
    rng = np.random.default_rng(0)
    merged, n = 0, 4000
    for _ in range(n):
        runs = rng.uniform(100.0, 800.0, size=2)
        sig = [math.hypot(0.01 * r, P.camera_sigma_m) for r in runs]
        centre = np.zeros(2)
        looks = []
        for s in sig:
            r, th = P.extent_m * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
            where = centre + [r * math.cos(th), r * math.sin(th)] + rng.normal(0, s, 2)
            looks.append(Estimate(tuple(where), s))
        merged += same_aggregation(*looks, P)
    assert merged / n == pytest.approx(P.gate_p, abs=0.01)


# -- the priority beside the position (feature-aided association) ---------------------------


def rated(pos, sigma_m: float, rho: float) -> Estimate:
    """A sighting at ``pos`` (navigation sigma ``sigma_m``) of COTS measured at ``rho``."""
    return sighting(pos, sigma_m, P, rho)


def test_the_priority_gate_is_the_chi_square_quantile_of_one_degree_of_freedom():
    assert chi2_gate_1(0.99) == pytest.approx(6.6349, abs=1e-4)
    assert chi2_gate_1(0.999) == pytest.approx(10.8276, abs=1e-4)


def test_a_rho_is_attached_only_where_its_error_is_known():
    assert sighting((0.0, 0.0), 1.0, P, 40.0).priority == 40.0
    assert sighting((0.0, 0.0), 1.0, P).priority is None
    off = AssociationParams(camera_priority_sigma=0.0)
    assert sighting((0.0, 0.0), 1.0, off, 40.0).priority is None
    # the map's priorities are not compared unless their error is given
    assert predicted((0.0, 0.0), P, 40.0).priority is None
    with_map = AssociationParams(map_priority_sigma=0.3)
    spot = predicted((0.0, 0.0), with_map, 40.0)
    assert (spot.priority, spot.priority_sigma) == (40.0, 0.3)


def test_two_aggregations_in_one_gate_are_told_apart_by_their_rho():
    """Hard reef, 1 % drift: a find's 0.99 gate between two 8 m estimates reaches 34 m, so
    by position an aggregation 20 m away was taken for it; its COTS (rho 13.7 against
    51) say it is another, while the same rho (the wire's 0.1 rounding) is the same one."""
    find = rated((0.0, 0.0), 8.0, 51.0)
    assert distance2(find, rated((20.0, 0.0), 8.0, 13.7), P) <= P.gate  # one, by position
    assert not same_aggregation(find, rated((20.0, 0.0), 8.0, 13.7), P)
    assert same_aggregation(find, rated((20.0, 0.0), 8.0, 51.03), P)
    assert resolve(rated((20.0, 0.0), 8.0, 13.7), [("find", find)], P) == (None, True)
    # 1.3x apart is within the camera's 10 % at 0.99 (|ln 1.3| = 0.26 < 2.58 * 0.14)
    assert same_aggregation(find, rated((20.0, 0.0), 8.0, 51.0 * 1.3), P)


def test_estimates_too_close_to_aim_between_are_one_whatever_their_rho():
    """Hard reef seed 6, 1 % drift: aggregations of rho 51 and 13.7 lie 1 m apart; named
    apart, the vehicle sent to the second injected the first again."""
    a, b = rated((0.0, 0.0), 2.0, 51.0), rated((0.8, 0.0), 2.5, 13.7)
    assert distance2(a, b, P) <= P.apart_gate
    assert same_aggregation(a, b, P) and probably_treated(b, [a], P)


def test_a_treated_aggregation_is_held_by_its_rho_too():
    treated = rated((0.0, 0.0), 3.0, 51.0)
    assert probably_treated(rated((15.0, 0.0), 3.0, 51.0), [treated], P)
    assert not probably_treated(rated((15.0, 0.0), 3.0, 13.7), [treated], P)
    # a treated estimate without a rho (an injection whose helm did not say) holds by
    # position alone, as before
    assert probably_treated(rated((15.0, 0.0), 3.0, 13.7), [sighting((0.0, 0.0), 3.0, P)], P)


def test_a_candidate_of_the_same_rho_outweighs_one_whose_rho_is_unknown():
    """A find of the measured rho against a predicted spot (rho not compared) at the same
    distance: the find, as likely as the Gaussian of ln rho over the spread of ln rho
    (13 times the spot's at the defaults); a find of a rho 2.5 sigma off (still inside the
    gate) loses to the spot."""
    seen = rated((0.0, 0.0), 2.0, 40.0)
    spot = predicted((5.0, 0.0), P, 40.0)
    same = rated((-5.0, 0.0), 2.0, 40.0)
    post = dict(posteriors(seen, [("spot", spot), ("find", same)], P))
    v = 2 * P.camera_priority_sigma ** 2
    ratio = math.exp(-0.5 * (math.log(v) + math.log(2 * math.pi))) * P.priority_log_span
    # both at the same d2; the spot is the map's sigma, the find the camera's: compare
    # their position likelihoods first
    s_spot = seen.sigma_m ** 2 + spot.sigma_m ** 2 + P.extent_var
    s_find = seen.sigma_m ** 2 + same.sigma_m ** 2 + P.extent_var
    pos_ratio = (s_spot / s_find) * math.exp(-12.5 / s_find + 12.5 / s_spot)
    assert post["find"] / post["spot"] == pytest.approx(ratio * pos_ratio, rel=1e-9)
    off = rated((-5.0, 0.0), 2.0, 40.0 * math.exp(2.5 * math.sqrt(v)))
    assert same_aggregation(seen, off, P)
    post = dict(posteriors(seen, [("spot", spot), ("find", off)], P))
    assert post["spot"] > post["find"]


def test_without_any_rho_the_rule_is_the_position_alone():
    """Estimates without a rho (a helm that does not say, or the camera's error set to 0)
    match exactly as before the priority was weighed."""
    off = AssociationParams(camera_priority_sigma=0.0)
    a, b = sighting((0.0, 0.0), 3.0, off, 51.0), sighting((20.0, 0.0), 3.0, off, 13.7)
    assert same_aggregation(a, b, off) == (distance2(a, b, off) <= off.gate)


def test_bad_priorities_are_refused():
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="priority"):
            Estimate((0.0, 0.0), 1.0, bad, 0.1)
    with pytest.raises(ValueError, match="priority_sigma"):
        Estimate((0.0, 0.0), 1.0, 40.0, -0.1)
    for name in ("camera_priority_sigma", "map_priority_sigma"):
        with pytest.raises(ValueError, match=name):
            AssociationParams(**{name: -1.0})
    with pytest.raises(ValueError, match="apart_p"):
        AssociationParams(apart_p=1.0)
    with pytest.raises(ValueError, match="priority_log_span"):
        AssociationParams(priority_log_span=0.0)


rhos = st.floats(0.0, 200.0, allow_nan=False)


@given(rhos, rhos, st.floats(0.0, 40.0), st.floats(0.5, 10.0))
def test_a_rho_only_ever_splits_what_the_position_would_merge(ra, rb, d, sigma):
    """Weighing the rho never merges two estimates the position keeps apart, and never
    splits two of one rho."""
    a, b = rated((0.0, 0.0), sigma, ra), rated((d, 0.0), sigma, rb)
    by_position = distance2(a, b, P) <= P.gate
    assert not same_aggregation(a, b, P) or by_position
    if ra == rb:
        assert same_aggregation(a, b, P) == by_position


def test_fusing_keeps_the_rho_in_logs():
    f = fuse(rated((0.0, 0.0), 1.0, 10.0), rated((2.0, 0.0), 1.0, 40.0))
    assert f.priority == pytest.approx(20.0)
    assert f.priority_sigma == pytest.approx(P.camera_priority_sigma / math.sqrt(2))
    assert fuse(rated((0.0, 0.0), 1.0, 10.0), Estimate((1.0, 0.0), 1.0)).priority == 10.0


@settings(max_examples=60)
@given(st.lists(st.tuples(st.floats(0.0, 60.0), st.floats(0.0, 60.0), st.floats(0.5, 8.0),
                          st.one_of(st.none(), st.floats(1.0, 100.0))),
                min_size=1, max_size=8))
def test_aliases_are_the_components_of_same_aggregation(rows):
    """`aliases` (every pair at once, vectorised) groups exactly as `same_aggregation`
    pair by pair, each group named by its lowest key, whatever the order given."""
    ests = [(10 + k, rated((x, y), s, rho) if rho is not None else sighting((x, y), s, P))
            for k, (x, y, s, rho) in enumerate(rows)]
    head = {k: k for k, _ in ests}

    def find(k: int) -> int:
        while head[k] != k:
            k = head[k]
        return k

    for i, (a, ea) in enumerate(ests):
        for b, eb in ests[i + 1:]:
            if same_aggregation(ea, eb, P):
                ha, hb = find(a), find(b)
                head[max(ha, hb)] = min(ha, hb)
    expected = {k: find(k) for k, _ in ests if find(k) != k}
    assert aliases(ests, P) == expected
    assert aliases(list(reversed(ests)), P) == expected
