"""The four HFC operators of the paper's section III, as small functions on an individual.

An individual is a fleet plan in the making: ``routes[v]`` lists the task indices vehicle ``v``
visits, in order. Operators have the shape ``op(routes, rng, **kw) -> routes`` and never modify
their input.
"""

from hfc_core.engines.operators.clustering import initial_routes
from hfc_core.engines.operators.cooperation import cooperate
from hfc_core.engines.operators.ordering import order
from hfc_core.engines.operators.screening import screen

__all__ = ["cooperate", "initial_routes", "order", "screen"]
