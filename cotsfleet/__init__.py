"""cotsfleet: the command line and launcher that tie hfc_core, fleet_agent, comms_sim and
ground_station together. Library code lives in those packages; this one only wires them."""
