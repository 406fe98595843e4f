"""What the planner reads: scenario documents (`scenario`, both ways) and Team Orienteering
Problem instances in Chao's format (`top`). Pure: they parse already-loaded data, never a file.
"""
