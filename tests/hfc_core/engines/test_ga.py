import numpy as np
import pytest

from hfc_core.engines.ga import GAParams, mutate, pmx
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.plan import vehicle_figures
from hfc_core.solve import solve
from reef_sim.scenarios.field import GeneratorParams, generate_doc


@pytest.fixture(scope="module")
def tight():
    params = GeneratorParams(n_tasks=30, n_vehicles=3, size_m=600.0, battery_s=1500.0,
                             service_s=60.0)
    return problem_from_dict(generate_doc(params, np.random.default_rng(4)))


def test_pmx_children_are_permutations_holding_a_slice_of_parent1():
    rng = np.random.default_rng(0)
    genes = [3, 17, 5, 8, 21, 2, 9, 11]
    for _ in range(200):
        p1 = rng.permutation(genes).tolist()
        p2 = rng.permutation(genes).tolist()
        child = pmx(p1, p2, rng)
        assert sorted(child) == sorted(genes)
        same = [c == a for c, a in zip(child, p1)]
        assert any(same)  # the copied slice keeps parent 1's genes in place
    assert pmx(genes, genes, rng) == genes


def test_mutation_keeps_the_genes():
    rng = np.random.default_rng(1)
    route = list(range(10))
    for _ in range(50):
        route = mutate(route, rng)
        assert sorted(route) == list(range(10))


def test_ga_is_feasible_seeded_and_drops_spots(tight):
    a = solve(tight, "ga", seed=3, population=20, max_iterations=60)
    b = solve(tight, "ga", seed=3, population=20, max_iterations=60)
    assert a.plan == b.plan
    assert len(a.history) == 60
    assert 0 < sum(f.tasks for f in vehicle_figures(tight, a.plan)) < tight.n_tasks
    assert max(a.history[-1].violation_s) == 0.0


def test_ga_with_single_move_mutation(tight):
    solve(tight, "ga", seed=3, population=10, max_iterations=20, mutation="move")


@pytest.mark.parametrize("bad", [dict(population=1), dict(crossover_rate=1.5),
                                 dict(elite=100), dict(tournament=0), dict(mutation="flip")])
def test_bad_params_are_rejected(bad):
    with pytest.raises(ValueError):
        GAParams(**bad)
