"""The problem model: what is planned, and the rules every plan is measured by.

Vehicles, spots and the distance and travel-time matrices (`problem`, paper eq. 2, 7-8); the
scenario error and its checks (`errors`); water currents (`current`), travel through them
(`travel`) and routes timed as flown in a tide (`tide_clock`); land and shortest paths around
it (`geometry`); the one feasibility rule (`feasibility`), the independent checker (`check`),
a plan and its figures (`plan`), and the eq. (9) cost (`cost`). Nothing here imports an engine
or an entry point.
"""
