"""cotsfleet: the command line and launcher that tie hfc_core, fleet_agent, comms_sim and
ground_station together. Library code lives in those packages; this one only wires them."""

__version__ = "0.1.0"  # kept equal to pyproject.toml's (tests/cotsfleet/test_cli_defects.py)
