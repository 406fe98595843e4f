"""The engines behind `hfc_core.solve`: the paper's HFC (`hfc`, its modes NCM1, NCM2, CM) and
its four operators (`operators`), the GA baseline (`ga`), and `best` (`best`), with what they
share (`history`: the Fig. 7-8 record of a plan; `params`: keyword parameters checked against
an engine's dataclass). Every engine has the shape ``engine(problem, stop, rng, **params) ->
SolveResult`` (`hfc_core.stop`, `hfc_core.result`).
"""
