"""fleet_agent: one process per AUV: vehicle model, plan execution, gossip, negotiation."""
