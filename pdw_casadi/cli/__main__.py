"""``python -m pdw_casadi.cli COMMAND [options]``."""

import sys

from pdw_casadi.cli import main

sys.exit(main())
