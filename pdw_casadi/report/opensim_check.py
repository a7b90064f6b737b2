"""Read an export back with OpenSim: marker positions, the force table, inverse dynamics.

Run as a script in its own process (:func:`pdw_casadi.report.opensim.read_back` does so):
the ``opensim`` wheel bundles its own CasADi under the same shared-library name as the
``casadi`` package (``libcasadi.so.3.7``), so one process cannot load both. This file
imports neither CasADi nor the toolkit, only numpy and OpenSim.

    python opensim_check.py MODEL MOTION EXTERNAL_LOADS REQUEST.npz RESULT.npz

REQUEST.npz holds ``forces_path`` (the force table), ``id_time`` (s) and, per coordinate
in ``coordinates`` (names), ``id_speed`` and ``id_acceleration`` (rad/s, rad/s^2, m/s,
m/s^2; rows: times) for the inverse dynamics, ``id_setup`` (optional: a setup file of
OpenSim's inverse-dynamics tool to run too). RESULT.npz gets OpenSim's numbers:
``marker_names``, ``marker_positions`` (frames x markers x 3, m, ground frame) and
``body_frames`` (frames x bodies x 4 x 3: each body frame's origin and its x, y, z axes
in ground, m) at every frame of the motion, ``motion_time``; ``force_columns``,
``force_time``, ``force_data`` (the force table as OpenSim reads it); ``id_forces`` (times
x coordinates, N m or N: the generalized forces of OpenSim's inverse dynamics with the
external loads applied, at the coordinates of the motion at those times);
``coordinate_names``, ``rotational``; ``slope`` (rad, from the orientation of the ground's
slope frame); ``masses`` (kg) of the bodies ``body_names`` and the model's total mass;
with ``id_setup``, the tool's ``tool_time``, ``tool_columns``, ``tool_data``.
"""

from __future__ import annotations

import os
import sys

import numpy as np


def _table(path: str):
    # deferred: OpenSim is optional and cannot share a process with CasADi (module docstring)
    import opensim as osim

    t = osim.TimeSeriesTable(path)
    column = t.getIndependentColumn()  # a copy per call: take it once
    time = np.array([column[i] for i in range(t.getNumRows())])
    cols = [t.getColumnLabel(i) for i in range(t.getNumColumns())]
    data = t.getMatrix().to_numpy() if t.getNumRows() else np.zeros((0, len(cols)))
    return time, cols, np.asarray(data), t


def read_back(model_path: str, motion_path: str, loads_path: str, request: dict) -> dict:
    """OpenSim's view of an export (see the module docstring)."""
    # deferred: OpenSim is optional and cannot share a process with CasADi (module docstring)
    import opensim as osim

    model = osim.Model(model_path)
    loads = osim.ExternalLoads(loads_path, True)
    model.addModelComponent(loads)
    state = model.initSystem()
    cs = model.getCoordinateSet()
    coord_names = [cs.get(i).getName() for i in range(cs.getSize())]
    rotational = [cs.get(i).getMotionType() == osim.Coordinate.Rotational
                  for i in range(cs.getSize())]

    m_time, m_cols, m_data, m_table = _table(motion_path)
    in_degrees = m_table.getTableMetaDataAsString("inDegrees").strip().lower() == "yes"
    # OpenSim knows which coordinates rotate: convert those from degrees
    scale = np.array([np.pi / 180 if in_degrees and rotational[coord_names.index(c)] else 1.0
                      for c in m_cols])
    q_all = m_data * scale
    ms = model.getMarkerSet()
    marker_names = [ms.get(i).getName() for i in range(ms.getSize())]
    positions = np.zeros((len(m_time), len(marker_names), 3))
    bs = model.getBodySet()
    body_names = [bs.get(i).getName() for i in range(bs.getSize())]
    # each body frame in ground: origin and the columns of its rotation (x, y, z axes)
    frames = np.zeros((len(m_time), len(body_names), 4, 3))
    col_coord = [cs.get(c) for c in m_cols]
    for i in range(len(m_time)):
        for c, v in zip(col_coord, q_all[i], strict=True):
            c.setValue(state, float(v), False)
        model.realizePosition(state)
        for k in range(len(marker_names)):
            loc = ms.get(k).getLocationInGround(state)
            positions[i, k] = [loc.get(0), loc.get(1), loc.get(2)]
        for k in range(len(body_names)):
            tr = bs.get(k).getTransformInGround(state)
            rot = tr.R().asMat33()
            frames[i, k, 0] = [tr.p().get(a) for a in range(3)]
            frames[i, k, 1:] = [[rot.get(a, c) for a in range(3)] for c in range(3)]

    f_time, f_cols, f_data, _ = _table(request["forces_path"])

    # inverse dynamics at the requested times: coordinates from the motion (as OpenSim read
    # it), speeds and accelerations given (the motion file holds positions only)
    solver = osim.InverseDynamicsSolver(model)
    # the solver works in the order of the mobilities (the state's U): find each
    # coordinate's slot by giving the speeds distinct values
    for k, n in enumerate(coord_names):
        cs.get(n).setSpeedValue(state, float(k + 1))
    u_now = [state.getU().get(i) for i in range(state.getNU())]
    tree_names = [coord_names[int(round(v)) - 1] for v in u_now]
    req_names = list(request["coordinates"])
    id_forces = np.zeros((len(request["id_time"]), len(coord_names)))
    for r, t in enumerate(request["id_time"]):
        i = int(np.argmin(np.abs(m_time - t)))
        if abs(m_time[i] - t) > 1e-12:
            raise ValueError(f"time {t} is not a frame of the motion")
        state.setTime(float(t))
        for c, v in zip(col_coord, q_all[i], strict=True):
            c.setValue(state, float(v), False)
        udot = osim.Vector(len(tree_names), 0.0)
        for c_name in req_names:
            j = req_names.index(c_name)
            cs.get(c_name).setSpeedValue(state, float(request["id_speed"][r, j]))
            udot.set(tree_names.index(c_name), float(request["id_acceleration"][r, j]))
        model.realizeVelocity(state)
        gen = solver.solve(state, udot)
        for k, n in enumerate(tree_names):
            id_forces[r, coord_names.index(n)] = gen.get(k)
    tool = {}
    if request.get("id_setup"):
        # OpenSim's own inverse-dynamics tool from the export's setup file: it splines the
        # coordinates and differentiates them (the way a user runs it)
        setup = os.path.abspath(request["id_setup"])
        cwd = os.getcwd()
        os.chdir(os.path.dirname(setup))  # the setup names its files relative to itself
        try:
            id_tool = osim.InverseDynamicsTool(setup)
            if not id_tool.run():
                raise RuntimeError(f"the inverse-dynamics tool failed on {setup}")
            out = os.path.join(id_tool.getResultsDir(), id_tool.getOutputGenForceFileName())
            t_time, t_cols, t_data, _ = _table(os.path.abspath(out))
        finally:
            os.chdir(cwd)
        tool = {"tool_time": t_time, "tool_columns": np.array(t_cols), "tool_data": t_data}
    # the walking surface: the ground's slope frame is rotated -slope about z
    surface = model.getComponent("/ground/slope").getTransformInGround(state).R().asMat33()
    slope = -float(np.arctan2(surface.get(1, 0), surface.get(0, 0)))
    return {
        "slope": slope,
        "marker_names": np.array(marker_names), "marker_positions": positions,
        "motion_time": m_time, "force_columns": np.array(f_cols), "force_time": f_time,
        "force_data": f_data, "id_forces": id_forces,
        "coordinate_names": np.array(coord_names), "rotational": np.array(rotational),
        "body_names": np.array(body_names), "body_frames": frames,
        "masses": np.array([bs.get(i).getMass() for i in range(bs.getSize())]),
        "total_mass": float(model.getTotalMass(state)),
        **tool,
    }


def main(argv: list[str]) -> int:
    model_path, motion_path, loads_path, request_path, result_path = argv
    with np.load(request_path, allow_pickle=False) as z:
        request = {k: z[k] for k in z.files}
    request["forces_path"] = str(request["forces_path"])
    request["id_setup"] = str(request.get("id_setup", ""))
    np.savez(result_path, **read_back(model_path, motion_path, loads_path, request))
    return 0


if __name__ == "__main__":
    # run as a script, this file's folder leads sys.path, and the exporter beside it
    # (opensim.py) would shadow the opensim package
    _here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _here]
    sys.exit(main(sys.argv[1:]))
