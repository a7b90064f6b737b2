"""pdw-casadi: passive dynamic walking with CasADi and IPOPT.

The API reads like the paper::

    from pdw_casadi import load_problem, simulate, poincare_map, find_fixed_point, fit_gait
    problem = load_problem("humanlike_6link")      # Tables 1-3, slope 0.1484 rad
    gait = find_fixed_point(problem)                 # Newton on the exact-AD Poincare map
    gait.eigenvalues, gait.spectral_radius, gait.margins
"""

from ._version import __version__
from .fit import FitOptions, fit_gait
from .fixed_point import find_fixed_point, stability
from .gait_data import load_gait_curves
from .poincare import poincare_map
from .problem import load_problem
from .simulate import simulate

__all__ = ["__version__", "FitOptions", "fit_gait", "find_fixed_point", "load_gait_curves",
           "load_problem", "poincare_map", "simulate", "stability"]
