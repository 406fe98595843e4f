"""The search belief and the value of a search (`fleet_agent.search`): the prior is the
generator's distribution, a positive spot raises what its surroundings are worth and an empty
one lowers it, a pass that sees nothing leaves 1 - p_detect, and a search is chosen only when
its numbers beat the next known spot."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_agent.search import (BeliefParams, SearchBelief, SearchOption, best_search,
                                evaluate, expanding_square, orbit, path_length_m,
                                worth_searching)

HARD = dict(empty_share=0.28, unmapped_share=0.45, unmapped_min_m=10.0, unmapped_max_m=70.0)
CAMERA = dict(speed_mps=1.0, detect_radius_m=25.0, p_detect=0.9)


def ring_params(**kw) -> BeliefParams:
    base = dict(per_spot=0.45, ring_min_m=10.0, ring_max_m=70.0, empty_weight=0.3, p_cots=0.72)
    return BeliefParams(**{**base, **kw})


def two_spots(params: BeliefParams) -> SearchBelief:
    return SearchBelief(params, np.array([[300.0, 300.0], [700.0, 700.0]]),
                        (0.0, 1000.0, 0.0, 1000.0))


# -- the prior --------------------------------------------------------------------------------


def test_the_prior_holds_the_missed_aggregations_around_the_spots():
    b = two_spots(ring_params())
    assert b.intensity().sum() * b.cell_area == pytest.approx(2 * 0.45, rel=1e-9)
    assert b.expected((300.0, 300.0), 75.0) == pytest.approx(0.45, rel=0.05)  # its ring
    assert b.expected((300.0, 300.0), 9.0) == 0.0  # never within the ring's inside
    assert b.expected((50.0, 950.0), 100.0) == 0.0  # far from every spot
    gauss = two_spots(BeliefParams(per_spot=0.45, spread_m=50.0))
    assert gauss.expected((300.0, 300.0), 3 * 50.0) == pytest.approx(0.45, rel=0.02)


def test_a_positive_spot_raises_its_surroundings_and_an_empty_one_lowers_them():
    b = two_spots(ring_params())
    near_a, near_b = b.expected((300.0, 300.0), 75.0), b.expected((700.0, 700.0), 75.0)
    b.learn(0, True)
    assert b.expected((300.0, 300.0), 75.0) > near_a
    b.learn(1, False)
    assert b.expected((700.0, 700.0), 75.0) < near_b
    # an empty spot anchors empty_weight times what a live one does
    assert b.expected((700.0, 700.0), 75.0) == pytest.approx(
        0.3 * b.expected((300.0, 300.0), 75.0), rel=1e-6)


def test_a_pass_that_sees_nothing_leaves_one_minus_p_detect():
    b = two_spots(ring_params())
    before = b.expected((300.0, 300.0), 75.0)
    b.swept(orbit((300.0, 300.0), 40.0), 25.0, 0.9)
    after = b.expected((300.0, 300.0), 75.0)
    assert after < 0.3 * before  # the orbit covered most of the ring
    # each pass leaves a tenth: the spokes to the ring and back cross it twice
    assert set(np.round(np.log10(b.miss)).tolist()) <= {0.0, -1.0, -2.0, -3.0}
    assert b.miss == pytest.approx(0.1 ** b.passes(orbit((300.0, 300.0), 40.0), 25.0))
    b.swept([(300.0, 300.0), (300.0, 300.0)], 25.0, 0.0)  # a blind camera changes nothing
    assert b.expected((300.0, 300.0), 75.0) == pytest.approx(after)


def test_passes_count_each_entry_into_reach_once():
    b = two_spots(ring_params())
    out_and_back = b.passes([(0.0, 500.0), (500.0, 500.0), (0.0, 500.0)], 25.0)
    straight = b.passes([(0.0, 500.0), (250.0, 500.0), (500.0, 500.0)], 25.0)
    cell = np.argmin(np.hypot(b._cells[:, 0] - 200.0, b._cells[:, 1] - 505.0))
    assert straight[cell] == 1  # the corner at 250 m is within reach: one pass
    assert out_and_back[cell] == 2  # the turn at 500 m is 300 m away: it left and came back
    far = np.argmin(np.hypot(b._cells[:, 0] - 200.0, b._cells[:, 1] - 600.0))
    assert straight[far] == 0


def test_the_belief_is_the_generators_distribution():
    """Over 40 drawn hard reefs (45 % unmapped, 10-70 m ring, 28 % empty, empty anchors at
    0.3), the belief with the truth's spot states predicts how many missed aggregations lie
    near live and near empty predicted spots."""
    from hfc_core.formats.scenario import problem_from_dict
    from reef_sim.scenarios.dynamic import DynamicParams, generate_dynamic_doc
    from reef_sim.truth import reef_from_doc

    params = DynamicParams(**HARD, empty_anchor_weight=0.3)
    belief_params = BeliefParams.for_generator(90, params.unmapped_count, empty_share=0.28,
                                               ring=(10.0, 70.0), empty_anchor_weight=0.3)
    counted = {"live": 0.0, "empty": 0.0}
    expected = {"live": 0.0, "empty": 0.0}
    for seed in range(40):
        doc = generate_dynamic_doc(params, np.random.default_rng(seed))
        problem = problem_from_dict(doc)
        reef = reef_from_doc(doc, problem)
        spots = problem.xyz[: problem.n_tasks, :2]
        b = SearchBelief(belief_params, spots, (0.0, 1000.0, 0.0, 1000.0))
        empty = set(reef.empty(problem.n_tasks))
        for i in range(problem.n_tasks):
            b.learn(i, i not in empty)
        unmapped = np.array([reef.spots[i].pos[:2] for i in reef.unmapped()])
        for kind, members in (("live", [i for i in range(90) if i not in empty]),
                              ("empty", sorted(empty))):
            # what lies within 40 m of one of these spots and of no spot of the other kind
            d_cells = np.linalg.norm(b._cells[:, None, :] - spots[None, members, :], axis=2)
            others = [i for i in range(90) if i not in members]
            d_other = np.linalg.norm(b._cells[:, None, :] - spots[None, others, :], axis=2)
            zone = (d_cells.min(axis=1) <= 40.0) & (d_other.min(axis=1) > 70.0)
            expected[kind] += float(b.intensity()[zone].sum() * b.cell_area)
            du = np.linalg.norm(unmapped[:, None, :] - spots[None, members, :], axis=2)
            dou = np.linalg.norm(unmapped[:, None, :] - spots[None, others, :], axis=2)
            counted[kind] += float(((du.min(axis=1) <= 40.0) & (dou.min(axis=1) > 70.0)).sum())
    assert counted["live"] > 40  # enough to judge by
    assert counted["live"] == pytest.approx(expected["live"], rel=0.2)
    assert counted["empty"] == pytest.approx(expected["empty"], rel=0.5, abs=4.0)
    assert counted["empty"] / max(1.0, expected["empty"]) < 2.0


# -- patterns and their value -----------------------------------------------------------------


def test_patterns_start_and_end_at_their_centre():
    for w in (orbit((10.0, 20.0), 40.0), expanding_square((10.0, 20.0), 50.0, 6)):
        assert w[0] == w[-1] == (10.0, 20.0)
    assert path_length_m(orbit((0.0, 0.0), 40.0, step_deg=1.0)) == pytest.approx(
        80.0 + 2 * math.pi * 40.0, rel=1e-3)
    assert path_length_m(expanding_square((0.0, 0.0), 50.0, 4)) == pytest.approx(
        50 + 50 + 100 + 100 + math.hypot(-50.0, -50.0))


def test_a_search_around_a_positive_spot_is_worth_more_than_one_around_an_empty_one():
    b = two_spots(ring_params())
    b.learn(0, True)
    b.learn(1, False)
    live = evaluate(b, orbit((300.0, 300.0), 40.0), **CAMERA)
    empty = evaluate(b, orbit((700.0, 700.0), 40.0), **CAMERA)
    assert live.expected_priority > 2 * empty.expected_priority > 0
    assert live.expected_finds == pytest.approx(live.expected_priority / 50.5)
    assert live.duration_s == pytest.approx(path_length_m(live.waypoints))
    assert live.time_s == pytest.approx(live.duration_s + live.expected_finds * 75.0)
    chosen = best_search(b, [(700.0, 700.0), (300.0, 300.0)], **CAMERA)
    assert chosen is not None and chosen.centre == (300.0, 300.0)
    assert best_search(b, [], **CAMERA) is None


def test_searching_a_place_already_swept_is_worth_little():
    b = two_spots(ring_params())
    b.learn(0, True)
    first = evaluate(b, orbit((300.0, 300.0), 40.0), **CAMERA)
    b.swept(orbit((300.0, 300.0), 40.0), 25.0, 0.9)
    again = evaluate(b, orbit((300.0, 300.0), 40.0), **CAMERA)
    assert again.expected_priority < 0.15 * first.expected_priority


# -- the choice -------------------------------------------------------------------------------


def option(priority: float, duration_s: float = 300.0, service_s: float = 30.0) -> SearchOption:
    return SearchOption((0.0, 0.0), ((0.0, 0.0),), duration_s, priority / 50.5, priority,
                        service_s)


def test_the_next_known_spot_wins_unless_the_search_is_worth_more_per_second():
    search = option(20.0)  # 20 expected over 30 s of way + 330 s: 0.056 per s
    assert not worth_searching(search, 30.0, spot_priority=50.0, spot_travel_s=100.0,
                               spot_service_s=75.0)  # 0.29 per s
    assert worth_searching(search, 30.0, spot_priority=10.0, spot_travel_s=300.0,
                           spot_service_s=75.0)  # 0.027 per s
    assert worth_searching(search, 30.0, spot_priority=0.0, spot_travel_s=0.0,
                           spot_service_s=0.0)  # nothing known left
    # ... never beyond the battery, and never for nothing
    assert not worth_searching(search, 30.0, 0.0, 0.0, 0.0, slack_s=300.0)
    assert not worth_searching(option(0.0), 0.0, 0.0, 0.0, 0.0)
    # a margin asks for more than a tie
    rate = 20.0 / 360.0
    assert worth_searching(search, 30.0, rate * 98.0, 24.0, 75.0)
    assert not worth_searching(search, 30.0, rate * 99.0, 24.0, 75.0)  # a tie: the spot
    assert not worth_searching(search, 30.0, rate * 98.0, 24.0, 75.0, margin=1.1)


@given(st.floats(0.0, 500.0), st.floats(0.0, 2000.0), st.floats(0.0, 2000.0),
       st.floats(0.0, 100.0), st.floats(0.0, 2000.0), st.floats(0.0, 90.0), st.floats(1.0, 5.0))
def test_worth_searching_is_the_comparison_of_rates(expected, duration, way, spot, spot_way,
                                                    service, more):
    search = option(expected, duration)
    chosen = worth_searching(search, way, spot, spot_way, service)
    if chosen:  # worth more, never less
        assert worth_searching(option(expected * more, duration), way, spot, spot_way,
                               service)
        assert expected / (way + search.time_s) > spot / (spot_way + service) \
            if spot_way + service > 0 else spot == 0
    else:  # a better spot never makes the search worth it
        assert not worth_searching(search, way, spot * more, spot_way, service)


def test_bad_belief_parameters_are_refused():
    for bad in (dict(per_spot=-1.0), dict(ring_min_m=10.0), dict(ring_min_m=70.0, ring_max_m=10.0),
                dict(p_cots=1.5), dict(cell_m=0.0)):
        with pytest.raises(ValueError):
            BeliefParams(**bad)
