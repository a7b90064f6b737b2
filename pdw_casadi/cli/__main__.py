"""``python -m pdw_casadi.cli COMMAND [options]``."""

import sys

from pdw_casadi.cli import main
from pdw_casadi.engine import interrupt

interrupt.EXIT_AT_ONCE[0] = True  # a process of its own: see pdw_casadi.cli.scripts
sys.exit(main())
