"""The agent's decisions: each policy reads the knowledge (`fleet_agent.knowledge`) and
returns intents (`fleet_agent.intents`) that the agent applies.

- `hearing`: what a frame from a peer changes (membership, cleared set, claims, finds, aborts)
  and what to answer;
- `discovery`: the reef as the camera shows it (sightings, looks, finds, aliases);
- `takeover`: a peer declared gone: replan the survivors over its spots, take a share;
- `cooperate`: the paper's cooperation operator, online (spare battery on free spots);
- `route`: the route kept true to what is known (and what a takeover or a cooperation may
  change of it);
- `replans`: what those ask the replanner (`hfc_core.replan`).
"""
