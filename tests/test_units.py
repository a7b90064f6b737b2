"""Units in every written name: the CSV columns carry theirs, the summaries a ``units`` block."""

from __future__ import annotations

import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.units import LEGS, PLAIN, SUFFIXES, Units


def _has_unit(column: str) -> bool:
    return column in PLAIN or any(column.endswith(s) for s in SUFFIXES)


@pytest.mark.parametrize("name", ["humanlike_6link", "compass_gait", "kneed_walker"])
def test_every_trajectory_and_event_column_names_its_unit(name):
    problem = load_problem(name)
    sim = Simulator(problem)
    res = sim.run(problem.state_vector(), problem.parameter_vector(), steps=1, record=True)
    units = Units(sim.hs)
    for table in (res.trajectory, res.events):
        written = units.frame(table)
        assert [c for c in written if not _has_unit(c)] == []
        # renaming only: the numbers are the table's
        assert written.set_axis(table.columns, axis=1).equals(table)
    q = sim.hs.model.q_names
    assert units.column(q[0]) == f"{q[0]}_rad" and units.column("d" + q[-1]) == f"d{q[-1]}_m_s"


def test_the_fixed_point_summary_names_a_unit_for_every_number():
    problem = load_problem("humanlike_6link")
    fp = find_fixed_point(problem)
    summary = fp.to_dict()
    units = Units(Simulator(problem).hs).summary(summary)
    for key in ("fixed_point", "parameters", "margins"):
        assert set(units[key]) == set(summary[key]), key
    assert units["fixed_point"]["dq1"] == "rad/s" and units["parameters"]["k_knee"] == "N m/rad"
    assert units["margins"]["II:min_clearance_toe2"] == "m"
    assert units["margins"]["foot_strike:impulse_foot2"] == "N s"
    assert units["margins"]["foot_strike:impulse_cop2_from_toe"] == "m"
    assert units["step_time_s"] == "s" and units["legs"] == LEGS
    numeric = [k for k, v in summary.items() if isinstance(v, float) and k not in PLAIN]
    assert set(numeric) <= set(units), set(numeric) - set(units)
