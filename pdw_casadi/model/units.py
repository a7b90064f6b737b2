"""Units of everything the toolkit writes: a ``units`` block for every summary and a unit in
every CSV column name.

The in-memory tables keep their short names (``q1``, ``N_foot1``); the writers pass them
through :func:`with_units` (``q1_rad``, ``N_foot1_N``, ``t_s``) and add
:func:`summary_units` to each summary. Units come from the walker where it declares them
(its coordinates, section state and validity margins, :mod:`pdw_casadi.model.margins`) and from
the toolkit's naming otherwise (``*_s``, ``*_m``, ``*_J``, ``*_deg``, ...).

Legs: ``1`` and ``2`` in names are roles, not sides: leg 1 is the stance leg of the step,
leg 2 its swing leg; the legs swap at every step (see :data:`LEGS`).
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from pdw_casadi.model.margins import spec_of

#: what the digits 1 and 2 in the names mean
LEGS = ("leg 1 = the stance leg of the step, leg 2 = its swing leg (roles, not left/right: "
        "the legs swap at every step)")
#: unit suffixes of names that already carry their unit (longest first)
SUFFIXES = {"_m_s": "m/s", "_rad_s": "rad/s", "_N_s": "N s", "_deg": "deg", "_rad": "rad",
            "_pct": "%", "_Nm": "N m", "_m": "m", "_s": "s", "_J": "J", "_N": "N"}
#: dimensionless and label columns
PLAIN = {"step", "phase", "event", "kind", "branch", "on_grid", "converged", "valid",
         "stable", "failure", "iterations", "method", "accepted", "spectral_radius",
         "stability_margin", "max_radius", "problem", "gait_file", "targets", "headline",
         "index", "steps_requested", "completed_steps", "resimulation_steps", "mode",
         "parameter", "name"}
#: entries whose unit needs words
DESCRIBED = {
    "residual": "norm of a section-state difference (rad and rad/s mixed)",
    "resimulation_deviation": "norm of a section-state difference (rad and rad/s mixed)",
    "distance_from_initial": "norm of a section-state difference (rad and rad/s mixed)",
    "eigenvalues": "dimensionless ([re, im] of each eigenvalue of dP/dx)",
    "poincare_states": "one section state per row (units as fixed_point / initial_state)",
}
#: compliance units by name prefix (stiffness, damping, angles)
COMPLIANCE_PREFIXES = (("k_", "N m/rad"), ("c_", "N m s/rad"), ("theta_", "rad"),
                       ("phi_", "rad"), ("ankle_rest", "rad"), ("r_", "m"))
#: body (anthropometry) units by name prefix: lengths, masses, inertias about the COM
BODY_PREFIXES = (("l_", "m"), ("m_", "kg"), ("J_", "kg m^2"))


#: SUFFIXES, the longest first (a name ends in the longest suffix it matches)
_SUFFIXES_LONGEST_FIRST = tuple(sorted(SUFFIXES.items(), key=lambda kv: -len(kv[0])))


def _suffix_unit(name: str) -> str | None:
    return next((u for s, u in _SUFFIXES_LONGEST_FIRST if name.endswith(s)), None)


def _coordinate_unit(name: str) -> str:
    """A coordinate or section-state entry: positions in m, angles in rad, rates per s."""
    rate = name.startswith("d") and len(name) > 1 and name[1] in "qxy"
    base = name[1:] if rate else name
    unit = "m" if base.startswith(("x_", "y_")) else "rad"
    return f"{unit}/s" if rate else unit


class Units:
    """The units of one walker's names
    (``hs``: its :class:`~pdw_casadi.model.hybrid.HybridSystem`)."""

    def __init__(self, hs):
        model = hs.model
        self.coordinates = {*model.q_names, *(f"d{n}" for n in model.q_names),
                            *model.state_names}
        self.specs = hs.margin_specs
        self.outputs = {name: m.unit for ms in hs.phase_margins.values() for _, name, m in ms}
        # the per-leg walker's names carry the leg role (k_ankle@1); units go by the key
        self.compliance = {n.partition("@")[0] for n in model.parameter_names if n != "slope"}

    def of(self, name: str) -> str | None:
        """The unit of a name (None: dimensionless or a label)."""
        name = str(name)
        if name in PLAIN or name.startswith(("r2_", "eig")):
            return None
        if name in ("t", "duration"):
            return "s"
        if name == "slope":
            return "rad"
        if name in self.coordinates:
            return _coordinate_unit(name)
        if name in self.outputs:
            return self.outputs[name]
        if name.startswith(("margin:", "param:")):
            return self.of(name.split(":", 1)[1])
        if (m := spec_of(name, self.specs)) is not None:
            return m.unit
        if name in self.compliance:
            return next((u for p, u in (*COMPLIANCE_PREFIXES, *BODY_PREFIXES)
                         if name.startswith(p)), None)
        side, dot, key = name.partition(".")
        if dot and side in ("left", "right"):  # a physical leg's value (stride parameters)
            return self.of(key)
        if (u := _suffix_unit(name)) is not None:
            return u
        if name.startswith("F_") or "_N_" in name:
            return "N"  # contact force components, released contact forces
        if name.startswith("cop_"):
            return "m"
        if name.endswith("_speed"):
            return "m/s"  # post-impact rise speeds of the checks
        return None

    def column(self, name: str) -> str:
        """``name`` with its unit appended (``q1`` -> ``q1_rad``), unless it has one."""
        unit = self.of(name)
        if unit is None or _suffix_unit(str(name)) == unit:
            return str(name)
        return f"{name}_" + unit.replace(" ", "_").replace("/", "_per_").replace(
            "m_per_s", "m_s").replace("rad_per_s", "rad_s")

    def frame(self, df: pd.DataFrame) -> pd.DataFrame:
        """``df`` with a unit in every column name that has one (a renamed copy)."""
        return df.rename(columns={c: self.column(c) for c in df.columns})

    def summary(self, summary: Mapping) -> dict:
        """The ``units`` block of a summary: each numeric entry's unit (tables entry by
        entry), plus what legs 1 and 2 mean."""
        out: dict = {}
        for key, value in summary.items():
            if key == "units":
                continue
            if isinstance(value, Mapping):
                sub = {k: u for k in value if (u := self.of(k)) is not None}
                if sub:
                    out[key] = sub
            elif (u := DESCRIBED.get(key) or self.of(key)) is not None:
                out[key] = u
        out["legs"] = LEGS
        return out


def with_units(df: pd.DataFrame, hs) -> pd.DataFrame:
    """``df`` (a trajectory, event or sweep table of ``hs``'s walker) with units in its
    column names, for writing."""
    return Units(hs).frame(df)


def summary_units(summary: Mapping, hs) -> dict:
    """The ``units`` block of a summary of ``hs``'s walker (see :meth:`Units.summary`)."""
    return Units(hs).summary(summary)
