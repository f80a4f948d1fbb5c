"""Gripper grasps in MuJoCo: the model the scorer scored, two soft fingertips.

A parallel-jaw grasp is scored as two soft contacts, one per pad at the centre of its patch
(:mod:`synth.scores.cones`: MuJoCo's condim-4 cone with the plan's ``mu`` and torsion). The
simulation puts exactly that model to the test: each pad becomes a force-limited fingertip
(:mod:`synth.sim.scene`) pressing at its contact along the contact's normal (the pad's, or
the part's where the pad touches with its rim), with ``condim`` 4,
the plan's ``mu`` and its torsion scaled with the part (the simulation scales the part to
``size``). So the simulation checks the scores, not the gripper's geometry: its palm and
fingers are not in the scene (the planner checked them against the part with FCL).

With a grip force ``F`` per finger, the least squeeze per weight ``s`` of a grasp for the
simulation's gravity (-z of the file) predicts the gravity stage. Measured on the top three
grasps of the cube, the prism and the bread (8 grasps): at ``F = 0.8 s`` times the weight all
fell, at ``0.95 s`` three of eight fell, at ``1.05 s`` and ``1.25 s`` none did; the scorer's
inscribed cone is conservative by up to ``1 / cos(pi / 8) = 1.08`` against MuJoCo's elliptic
one (``tests/test_sim_jaws.py`` checks 0.7 and 1.5).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from synth.sim.contact import ContactModel
from synth.sim.document import GraspFile, SimGrasp
from synth.sim.settings import SimSettings
from synth.sim.simulate import labelled_document, simulate_file

__all__ = ["TIP_RTOL", "jaw_grasp_file", "simulate_jaw_document"]

#: Radius of the simulated fingertips, as a fraction of the part's size.
TIP_RTOL: float = 0.02


def jaw_grasp_file(doc: dict[str, Any], part: Any, mesh_path: str | Path) -> GraspFile:
    """A ``synth.gripper_grasps`` document as a grasp file the simulation reads.

    Parameters
    ----------
    doc : dict
        From :meth:`synth.plan.gripper.GripperPlan.to_json`.
    part : Part
        The part it was planned on.
    mesh_path : str or Path
        Its mesh file.

    Returns
    -------
    GraspFile
        One fingertip per pad, touching its contact from outside along the contact's normal.
    """
    r = TIP_RTOL * float(part.length)
    grasps = []
    for g in doc["grasps"]:
        P = np.array([c["point"] for c in g["contacts"]], float)
        N = np.array([c["normal"] for c in g["contacts"]], float)
        grasps.append(SimGrasp(P, N, P - r * N, -N, r,
                               {"d_star": g["measures"]["d_star"]}))
    return GraspFile(str(mesh_path), Path(mesh_path), None, float(part.length),
                     np.asarray(part.center_mass, float), float(part.volume),
                     float(doc["model"]["mu"]), tuple(grasps), doc)


def simulate_jaw_document(doc: dict[str, Any], part: Any, mesh_path: str | Path,
                          settings: SimSettings | None = None, mu: float | None = None,
                          **kwargs: Any) -> dict[str, Any]:
    """Simulate every grasp of a gripper plan's document; the document with ``sim`` labels.

    Parameters
    ----------
    doc : dict
        A ``synth.gripper_grasps`` document with at least one grasp.
    part : Part
    mesh_path : str or Path
    settings : SimSettings, optional
    mu : float, optional
        Simulate with this friction coefficient instead of the plan's ``model.mu`` (the
        document keeps its own; the label's ``contact`` says what was simulated).
    **kwargs
        Passed to :func:`synth.sim.simulate_file` (``cache``, ``progress``).

    Returns
    -------
    dict
        ``doc`` with each grasp's ``sim`` label and the run's ``sim`` summary.
    """
    st = settings or SimSettings()
    file = jaw_grasp_file(doc, part, mesh_path)
    torsion = float(doc["model"]["torsion"]) * st.size / float(part.length)
    report = simulate_file(file, st, contact=ContactModel(file.mu if mu is None else mu,
                                                          torsion), **kwargs)
    return labelled_document(file, report)
