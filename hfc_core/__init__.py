"""hfc_core: the pure mission planner (numpy/scipy only; no Zenoh, no Rerun, no clock, no I/O).

Paper: Abbasi, MahmoudZadeh, Yazdani, "A Cooperative Dynamic Task Assignment Framework for
COTSBot AUVs" (``../shared/paper/hfc_cotsbot_paper.md``).
"""

from hfc_core.model.errors import ScenarioError
from hfc_core.model.plan import Plan, plan_to_dict, vehicle_figures
from hfc_core.model.problem import Problem, Task, Vehicle

__all__ = ["Plan", "Problem", "ScenarioError", "Task", "Vehicle", "plan_to_dict", "vehicle_figures"]
