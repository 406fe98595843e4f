"""Adapters to the reference solvers the benchmarks run beside `best` (the `bench` extra).

Both solvers want integers, so distances, durations and budgets are scaled by ``SCALE`` and
rounded to the nearest integer. Rounding can let a route through that is a hair too long in
exact arithmetic: callers must check every returned plan with `hfc_core.model.check` (the
benchmarks do, and report how many needed a repair).

- PyVRP: prize-collecting; every spot is an optional client whose prize is its priority. The
  edge "distance" is mission time (travel at the vehicle type's speed plus the service of the
  spot reached) and the battery is the vehicle type's ``max_distance``: for the TOP that is
  the usual route-length limit, and it lets travel cost break ties between equal prizes.
- OR-Tools routing: one disjunction per spot with its scaled priority as the drop penalty, a
  time dimension (travel at the vehicle's speed plus the service of the node left) capped at the
  battery, guided local search.

Both return ``routes[v]``: task indices per vehicle of the `Problem`.
"""

from __future__ import annotations

import numpy as np

from hfc_core.model.problem import Problem

SCALE = 10_000  # 1e-4 m and 1e-4 s resolution


def _scaled(x: np.ndarray | float) -> np.ndarray:
    return np.rint(np.asarray(x, dtype=float) * SCALE).astype(np.int64)


PRIZE_ROUTES = 0.2


def _prize_factor(problem: Problem) -> int:
    """Scaled value of one priority point: the time of PRIZE_ROUTES full batteries. Priority
    must dominate travel, but much larger factors make PyVRP's penalty manager hit its bounds;
    0.2 was the best of 0.01-1.0 on the 33 TOP instances (0.31% mean gap at 5 s vs 0.52% at
    1.0 and 1.06% at 0.05)."""
    fleet = max(v.battery_s * v.speed_mps for v in problem.vehicles)
    return int(max(1.0, PRIZE_ROUTES * fleet * SCALE))


def solve_pyvrp(problem: Problem, time_limit_s: float, seed: int = 0) -> list[list[int]]:
    from pyvrp import Model
    from pyvrp.stop import MaxRuntime

    n = problem.n_tasks
    model = Model()
    # One depot per distinct station point; one profile per distinct speed.
    depot_of: dict[tuple[float, ...], object] = {}
    node_of_depot: list[int] = []
    for v in range(problem.n_vehicles):
        for node in (problem.start_node(v), problem.end_node(v)):
            key = tuple(problem.xyz[node])
            if key not in depot_of:
                depot_of[key] = model.add_depot(model.add_location(*key[:2]))
                node_of_depot.append(node)
    weight = _prize_factor(problem)
    # Priorities are floats in the paper preset: keep two decimals.
    prize = np.rint(problem.priority * 100).astype(np.int64) * max(1, weight // 100)
    for u in range(n):
        model.add_client(model.add_location(*problem.xyz[u, :2]),
                         prize=int(prize[u]), required=False)
    speeds = sorted({v.speed_mps for v in problem.vehicles})
    profiles = {s: model.add_profile() for s in speeds} if len(speeds) > 1 else {speeds[0]: None}
    groups: dict[tuple, list[int]] = {}
    for v, vehicle in enumerate(problem.vehicles):
        key = (tuple(vehicle.start), tuple(vehicle.rendezvous), vehicle.battery_s,
               vehicle.speed_mps)
        groups.setdefault(key, []).append(v)
    for (start, end, battery, speed), members in groups.items():
        model.add_vehicle_type(
            num_available=len(members), start_depot=depot_of[start], end_depot=depot_of[end],
            max_distance=int(_scaled(battery)), profile=profiles[speed],
            name=",".join(str(v) for v in members),
        )
    nodes = node_of_depot + list(range(n))
    locations = model.locations
    service = np.concatenate([np.zeros(len(node_of_depot)), problem.service_s])
    for speed, profile in profiles.items():
        # "Distance" is mission time: travel at this speed plus the service of the node reached.
        travel = _scaled(problem.dist_m[np.ix_(nodes, nodes)] / speed + service[None, :])
        dist = travel
        for i, a in enumerate(locations):
            for j, b in enumerate(locations):
                if i != j:
                    model.add_edge(a, b, distance=int(dist[i, j]), duration=int(travel[i, j]),
                                   profile=profile)
    result = model.solve(MaxRuntime(time_limit_s), seed=seed, display=False)
    routes: list[list[int]] = [[] for _ in range(problem.n_vehicles)]
    free = {key: list(members) for key, members in groups.items()}
    keys = list(groups)
    for route in result.best.routes():
        v = free[keys[route.vehicle_type()]].pop(0)
        routes[v] = [int(act.idx) for act in route.schedule() if act.is_client()]
    return routes


def solve_ortools(problem: Problem, time_limit_s: float, seed: int = 0) -> list[list[int]]:
    from ortools.constraint_solver import pywrapcp, routing_enums_pb2

    n, k = problem.n_tasks, problem.n_vehicles
    m = n + 2 * k
    starts = [problem.start_node(v) for v in range(k)]
    ends = [problem.end_node(v) for v in range(k)]
    manager = pywrapcp.RoutingIndexManager(m, k, starts, ends)
    routing = pywrapcp.RoutingModel(manager)
    dist = _scaled(problem.dist_m).tolist()
    service = np.zeros(m)
    service[:n] = problem.service_s
    arc = routing.RegisterTransitCallback(
        lambda i, j: dist[manager.IndexToNode(i)][manager.IndexToNode(j)])
    routing.SetArcCostEvaluatorOfAllVehicles(arc)
    time_callbacks = []
    for vehicle in problem.vehicles:
        step = _scaled(problem.dist_m / vehicle.speed_mps + service[:, None]).tolist()
        time_callbacks.append(routing.RegisterTransitCallback(
            lambda i, j, step=step: step[manager.IndexToNode(i)][manager.IndexToNode(j)]))
    budgets = [int(_scaled(v.battery_s)) for v in problem.vehicles]
    routing.AddDimensionWithVehicleTransitAndCapacity(time_callbacks, 0, budgets, True, "time")
    per_point = max(1, _prize_factor(problem) // 100)
    penalty = np.rint(problem.priority * 100).astype(np.int64) * per_point
    for u in range(n):
        routing.AddDisjunction([manager.NodeToIndex(u)], int(penalty[u]))
    params = pywrapcp.DefaultRoutingSearchParameters()
    params.first_solution_strategy = routing_enums_pb2.FirstSolutionStrategy.PATH_CHEAPEST_ARC
    params.local_search_metaheuristic = (
        routing_enums_pb2.LocalSearchMetaheuristic.GUIDED_LOCAL_SEARCH)
    params.time_limit.FromMilliseconds(int(time_limit_s * 1000))
    solution = routing.SolveWithParameters(params)
    routes: list[list[int]] = [[] for _ in range(k)]
    if solution is None:
        return routes
    for v in range(k):
        index = routing.Start(v)
        while not routing.IsEnd(index):
            node = manager.IndexToNode(index)
            if node < n:
                routes[v].append(node)
            index = solution.Value(routing.NextVar(index))
    return routes
