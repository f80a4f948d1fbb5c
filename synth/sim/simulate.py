"""Simulate every grasp of a grasp file and write the labels back into it.

:func:`simulate_file` builds the part's convex pieces once, then for each grasp compiles its
scene (:mod:`synth.sim.scene`), runs the protocol (:mod:`synth.sim.protocol`) and labels it
(:mod:`synth.sim.label`). :func:`labelled_document` returns the grasp document with a ``sim``
object added to each grasp and one describing the run at the top.
"""

from __future__ import annotations

import copy
import hashlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from synth.errors import InputError
from synth.sim.contact import ContactModel
from synth.sim.document import GraspFile
from synth.sim.label import SimLabel, label_run, predicted_escape
from synth.sim.pieces import ConvexPieces, convex_pieces
from synth.sim.protocol import run_protocol
from synth.sim.scene import build_scene
from synth.sim.settings import SimSettings

__all__ = ["SimReport", "simulate_file", "labelled_document", "check_mesh", "require_sim"]


@dataclass(frozen=True)
class SimReport:
    """The labels of every grasp of a file and how they were made.

    Attributes
    ----------
    labels : tuple of SimLabel
        One per grasp, in the file's order.
    settings : SimSettings
    contact : ContactModel
    pieces : ConvexPieces
        The part as simulated.
    seconds : float
        Wall-clock time of the whole run, decomposition included.
    """

    labels: tuple[SimLabel, ...]
    settings: SimSettings
    contact: ContactModel
    pieces: ConvexPieces = field(repr=False)
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """The top-level ``sim`` object of a labelled grasp file."""
        p = self.pieces
        return {
            "settings": self.settings.to_dict(),
            "contact": {"mu": self.contact.mu, "torsion": self.contact.torsion,
                        "condim": self.contact.condim, "cone": "elliptic"},
            "pieces": len(p.pieces),
            "bodies": p.bodies,
            "decomposed": p.decomposed,
            "decomposition_error": None if p.error != p.error else p.error,
            "held": sum(lab.held for lab in self.labels),
            "seconds": self.seconds,
        }


def require_sim() -> None:
    """Refuse to simulate without the optional packages (mujoco, coacd).

    Raises
    ------
    InputError
        Naming the missing package and the extra that installs it.
    """
    import importlib

    for name in ("mujoco", "coacd"):
        try:
            importlib.import_module(name)
        except ImportError:
            raise InputError(f"simulation needs the packages mujoco and coacd, and {name} is "
                             "not installed: pip install 'synth[sim]'") from None


def check_mesh(file: GraspFile) -> None:
    """Refuse a grasp file whose mesh is missing or has changed since it was planned.

    Raises
    ------
    InputError
        Naming the grasp file, the mesh and what is wrong.
    """
    path = file.mesh_path
    if not path.is_file():
        raise InputError(f"{file.path}: field mesh.path: {path}: no such file (give the mesh "
                         "with --mesh)")
    if file.sha256 is not None:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        if digest != file.sha256:
            raise InputError(f"{file.path}: field mesh.sha256: {path} has changed since the "
                             f"grasps were planned (sha256 {digest[:12]}..., the file says "
                             f"{file.sha256[:12]}...)")


def simulate_file(file: GraspFile, settings: SimSettings | None = None, *,
                  contact: ContactModel | None = None, cache: Any = True,
                  progress: Callable[[int, int], None] | None = None) -> SimReport:
    """Simulate every grasp of a checked grasp file.

    Parameters
    ----------
    file : GraspFile
        From :func:`synth.sim.read_grasp_file` (its mesh must be where ``mesh.path`` says).
    settings : SimSettings, optional
        The hand and the disturbances (default :class:`SimSettings`).
    contact : ContactModel, optional
        Default: the grasps' own, frictionless or with the file's ``params.mu``.
    cache : pathlib.Path, True or None
        Where convex decompositions are cached (see :func:`synth.sim.convex_pieces`).
    progress : callable, optional
        Called with (grasps done, grasps) after each grasp.

    Returns
    -------
    SimReport

    Examples
    --------
    >>> from synth.sim import read_grasp_file, simulate_file  # doctest: +SKIP
    >>> report = simulate_file(read_grasp_file("cube.grasps.json"))
    >>> [lab.held for lab in report.labels]
    [True, True, True]
    """
    t0 = time.perf_counter()
    st = settings or SimSettings()
    model = contact or ContactModel(file.mu)
    check_mesh(file)
    labels: list[SimLabel] = []
    if not file.grasps:
        raise InputError(f"{file.path}: field grasps: no grasp to simulate")
    pieces = convex_pieces(file.mesh_path, file.grasps[0].points, seed=st.seed, cache=cache)
    for i, g in enumerate(file.grasps):
        scene = build_scene(pieces, g.tip_centers, g.approach, g.tip_radius,
                            length=file.length, center_mass=file.center_mass,
                            volume=file.volume, settings=st, contact=model,
                            mesh_name=str(file.mesh_path))
        escape = predicted_escape(g.points, g.normals, model.mu, file.center_mass,
                                  file.length, model.torsion * file.length / st.size)
        labels.append(label_run(run_protocol(scene), scene, escape))
        if progress is not None:
            progress(i + 1, len(file.grasps))
    return SimReport(tuple(labels), st, model, pieces, time.perf_counter() - t0)


def labelled_document(file: GraspFile, report: SimReport) -> dict[str, Any]:
    """The grasp document with each grasp's ``sim`` label and the run's ``sim`` summary."""
    doc = copy.deepcopy(file.document)
    for g, lab in zip(doc["grasps"], report.labels):
        g["sim"] = lab.to_dict()
    doc["sim"] = report.to_dict()
    return doc
