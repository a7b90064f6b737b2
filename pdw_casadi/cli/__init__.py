"""Console scripts of the toolkit.

Each command is a ``*_main(argv=None)`` function registered in :data:`COMMANDS` and exposed
as a console script in ``pyproject.toml`` (``pdw-simulate`` -> :func:`simulate_main`). All of
them keep the contract of :mod:`pdw_casadi.cli.contract`: every argument, file, number,
bound and address is checked before the output directory is created; bad input is one line
``error: ...`` and exit code 2 with nothing written; "ran, but no gait" is exit code 1 with
a ``no gait: <reason>`` line; never a traceback; Ctrl-C ends with one line naming what is on
disk. They share:

- :func:`common_parser`: the parent argparse parser with ``--problem``, ``--state``,
  ``--compliance`` and ``--out``;
- :func:`load_cli_problem`: the problem with the ``--state`` / ``--compliance`` overrides
  applied (overrides obey the problem's ``compliance_bounds``);
- :func:`pdw_casadi.engine.jsonio.write_json`: JSON output with numpy scalars/arrays, paths and
  non-finite floats (written as ``null``) handled.

Adding a command: write ``foo_main(argv=None)`` that builds a
:class:`~pdw_casadi.cli.contract.Parser` with ``parents=[common_parser()]``, validates in a
``body()`` before ``outputs.create()`` and returns ``run(outputs, body)``; add it to
:data:`COMMANDS` (``python -m pdw_casadi.cli foo ...`` then works too).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

from pdw_casadi.cli.atlas import atlas_main
from pdw_casadi.cli.common import common_parser, load_cli_problem
from pdw_casadi.cli.contract import USER_ERRORS, fail
from pdw_casadi.cli.design import design_main
from pdw_casadi.cli.fit import fit_main, load_fit_start
from pdw_casadi.cli.fixed_point import fixed_point_main
from pdw_casadi.cli.scale import scale_main
from pdw_casadi.cli.simulate import simulate_main
from pdw_casadi.cli.sweep import sweep_main

__all__ = ["COMMANDS", "USER_ERRORS", "common_parser", "fit_main", "fixed_point_main",
           "load_cli_problem", "load_fit_start", "main", "simulate_main", "sweep_main",
           "scale_main", "design_main", "atlas_main"]


#: command name -> main function (for ``python -m pdw_casadi.cli COMMAND ...``)
COMMANDS: dict[str, Callable[[Sequence[str] | None], int]] = {
    "simulate": simulate_main,
    "fixed-point": fixed_point_main,
    "fit": fit_main,
    "sweep": sweep_main,
    "scale": scale_main,
    "design": design_main,
    "atlas": atlas_main,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``python -m pdw_casadi.cli COMMAND [options]`` to a command's main."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        fail(f"usage: python -m pdw_casadi.cli {{{','.join(COMMANDS)}}} [options]; "
              f"got {argv[0] if argv else 'no command'!r}")
    return COMMANDS[argv[0]](argv[1:])

