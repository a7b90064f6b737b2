"""Console scripts of the toolkit.

Each command is a ``*_main(argv=None)`` function registered in :data:`COMMANDS` and exposed
as a console script in ``pyproject.toml`` (``pdw-simulate`` ->
:func:`~pdw_casadi.cli.simulate.simulate_main`). All of them keep the contract of
:mod:`pdw_casadi.cli.contract`: every argument, file, number, bound and address is checked
before the output directory is created; bad input is one line ``error: ...`` and exit code 2
with nothing written; "ran, but no gait" is exit code 1 with a ``no gait: <reason>`` line;
never a traceback; Ctrl-C ends with one line naming what is on disk. They share:

- :func:`~pdw_casadi.cli.common.common_parser`: the parent argparse parser with
  ``--problem``, ``--state``, ``--compliance`` and ``--out``;
- :func:`~pdw_casadi.cli.common.load_cli_problem`: the problem with the ``--state`` /
  ``--compliance`` overrides applied (overrides obey the problem's ``compliance_bounds``);
- :func:`pdw_casadi.engine.jsonio.write_json`: JSON output with numpy scalars/arrays, paths
  and non-finite floats (written as ``null``) handled.

Adding a command: write ``foo_main(argv=None)`` that builds a
:class:`~pdw_casadi.cli.contract.Parser` with ``parents=[common_parser()]``, validates in a
``body()`` before ``outputs.create()`` and returns ``run(outputs, body)``; add it to
:data:`COMMANDS` (``python -m pdw_casadi.cli foo ...`` then works too).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from importlib import import_module

from pdw_casadi.cli.contract import fail

__all__ = ["COMMANDS", "USER_ERRORS", "cohort_main", "common_parser", "fit_main",
           "fixed_point_main",
           "load_cli_problem", "load_fit_start", "main", "simulate_main", "sweep_main",
           "scale_main", "design_main", "atlas_main", "seed_main", "compare_main"]

#: where each public name lives; imported on first use, so that a console script can take
#: over Ctrl-C before the seconds of numerics imports (:mod:`pdw_casadi.cli.scripts`)
_NAMES = {
    "simulate_main": "simulate", "fixed_point_main": "fixed_point", "fit_main": "fit",
    "load_fit_start": "fit", "sweep_main": "sweep", "scale_main": "scale",
    "design_main": "design", "atlas_main": "atlas", "cohort_main": "cohort",
    "seed_main": "seed", "compare_main": "compare",
    "common_parser": "common",
    "load_cli_problem": "common", "USER_ERRORS": "contract", "fail": "contract",
}


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(import_module(f"pdw_casadi.cli.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _command(function: str) -> Callable[[Sequence[str] | None], int]:
    def main(argv: Sequence[str] | None = None) -> int:
        return __getattr__(function)(argv)
    main.__name__ = main.__qualname__ = function
    main.__doc__ = f"{function} (imported on first call)."
    return main


#: command name -> main function (for ``python -m pdw_casadi.cli COMMAND ...``)
COMMANDS: dict[str, Callable[[Sequence[str] | None], int]] = {
    "simulate": _command("simulate_main"),
    "fixed-point": _command("fixed_point_main"),
    "fit": _command("fit_main"),
    "sweep": _command("sweep_main"),
    "scale": _command("scale_main"),
    "design": _command("design_main"),
    "atlas": _command("atlas_main"),
    "cohort": _command("cohort_main"),
    "seed": _command("seed_main"),
    "compare": _command("compare_main"),
}


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``python -m pdw_casadi.cli COMMAND [options]`` to a command's main."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        fail(f"usage: python -m pdw_casadi.cli {{{','.join(COMMANDS)}}} [options]; "
             f"got {argv[0] if argv else 'no command'!r}")
    return COMMANDS[argv[0]](argv[1:])
