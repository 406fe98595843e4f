"""Scenario generators, pure and seeded: the paper's eq. (1) field and preset (`field`), large
areas of compact aggregations (`area`), dynamic scenarios with a hidden reef (`dynamic`), and
the seabed they give depths from (`seabed`).
"""
