"""pdw-casadi: passive dynamic walking with CasADi and IPOPT.

The API reads like the paper::

    from pdw_casadi import (load_problem, simulate, poincare_map,
                            find_fixed_point, fit_gait)
    problem = load_problem("humanlike_6link")  # Tables 1-3, slope 0.1484 rad
    gait = find_fixed_point(problem)  # Newton on the exact-AD Poincare map
    gait.eigenvalues, gait.spectral_radius, gait.margins

The package is layered; each sub-package imports only the layers below it:
``engine`` -> ``model`` -> ``gait`` -> ``nlp`` -> ``fit`` -> ``studies`` -> ``report`` ->
``cli``. Importing ``pdw_casadi`` loads none of them: the names below are resolved on first
use.
"""

from importlib import import_module

from pdw_casadi._version import __version__

_LAZY = {
    "FitOptions": "pdw_casadi.fit.options",
    "fit_gait": "pdw_casadi.fit.core",
    "find_fixed_point": "pdw_casadi.gait.fixed_point",
    "stability": "pdw_casadi.gait.fixed_point",
    "load_gait_curves": "pdw_casadi.model.gait_data",
    "poincare_map": "pdw_casadi.gait.poincare",
    "load_problem": "pdw_casadi.model.problem",
    "simulate": "pdw_casadi.gait.simulate",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'pdw_casadi' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
