"""`UsageError`: bad input from the user (a flag, a file), as opposed to a bad scenario
(`hfc_core.model.errors.ScenarioError`). The command line prints either as one line and exits
with code 2, no traceback. It lives apart from `cotsfleet.cli` because the commands raise it and
the command line imports the commands.
"""


class UsageError(Exception):
    """Bad input from the user: printed as one line, exit code 2, no traceback."""
