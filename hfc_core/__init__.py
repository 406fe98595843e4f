"""hfc_core: the pure mission planner (numpy/scipy only; no Zenoh, no Rerun, no clock, no I/O).

Paper: Abbasi, MahmoudZadeh, Yazdani, "A Cooperative Dynamic Task Assignment Framework for
COTSBot AUVs" (``../shared/paper/hfc_cotsbot_paper.md``).
"""

from hfc_core.plan import Plan, plan_to_dict, vehicle_figures
from hfc_core.problem import Problem, ScenarioError, Task, Vehicle

__all__ = ["Plan", "Problem", "ScenarioError", "Task", "Vehicle", "plan_to_dict", "vehicle_figures"]
