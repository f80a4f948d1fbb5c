"""Physics as the judge: each grasp of a grasp file simulated in MuJoCo and labelled.

The data path: a grasp file (:mod:`~synth.sim.document`) names its mesh, whose bodies become
convex pieces (:mod:`~synth.sim.pieces`, CoACD for the non-convex ones); each grasp becomes a
MuJoCo scene (:mod:`~synth.sim.scene`) of the part and force-limited point fingers with the
grasp's contact model (:mod:`~synth.sim.contact`) and a hand (:mod:`~synth.sim.settings`);
the protocol (:mod:`~synth.sim.protocol`) squeezes, adds gravity, pushes and shakes; the label
(:mod:`~synth.sim.label`) says whether it held, how much, and how it moved. Needs the
optional extra ``synth[sim]`` (mujoco, coacd).
"""

from __future__ import annotations

from synth.sim.contact import ContactModel
from synth.sim.document import GraspFile, SimGrasp, check_document, read_grasp_file
from synth.sim.label import Escape, SimLabel, label_run, predicted_escape
from synth.sim.pieces import ConvexPieces, cache_dir, convex_pieces
from synth.sim.protocol import DIRECTIONS, SimRun, run_protocol
from synth.sim.scene import Scene, build_scene
from synth.sim.settings import SimSettings
from synth.sim.simulate import SimReport, check_mesh, labelled_document, require_sim, simulate_file

__all__ = [
    "ContactModel",
    "GraspFile",
    "SimGrasp",
    "check_document",
    "read_grasp_file",
    "Escape",
    "SimLabel",
    "label_run",
    "predicted_escape",
    "ConvexPieces",
    "cache_dir",
    "convex_pieces",
    "DIRECTIONS",
    "SimRun",
    "run_protocol",
    "Scene",
    "build_scene",
    "SimSettings",
    "SimReport",
    "check_mesh",
    "labelled_document",
    "require_sim",
    "simulate_file",
]
