"""``python -m pdw_casadi.cli COMMAND [options]``."""

from pdw_casadi.cli.scripts import dispatch

dispatch()
