"""Simulate every grasp of a grasp file on the part that was planned, and label it.

:func:`simulate_file` loads the part again with the loader and options the plan used (or
takes the :class:`~synth.part.Part` the planner just used), builds its collision shape once
(:mod:`synth.sim.shape`), then for each grasp computes the hand's squeeze
(:func:`balanced_preload`), compiles its scene
(:mod:`synth.sim.scene`), runs the protocol (:mod:`synth.sim.protocol`) and labels it
(:mod:`synth.sim.label`). A failure of synth's own (a MuJoCo compile) gives the grasps
it touches an error label with the reason; it never stops the run nor discards a plan.
:func:`labelled_document` returns the grasp document with a ``sim`` object added to each grasp
and one describing the run at the top.
"""

from __future__ import annotations

import copy
import hashlib
import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, SimulationError
from synth.sim.contact import ContactModel
from synth.sim.document import GraspFile, SimGrasp
from synth.sim.label import SimLabel, error_label, label_run, predicted_escape, start_label
from synth.sim.settings import SimSettings

__all__ = ["SimReport", "simulate_file", "labelled_document", "check_mesh", "require_sim",
           "load_planned_part", "balanced_preload"]


@dataclass(frozen=True)
class SimReport:
    """The labels of every grasp of a file and how they were made.

    Attributes
    ----------
    labels : tuple of SimLabel
        One per grasp, in the file's order.
    settings : SimSettings
    contact : ContactModel
    shape : PartShape or None
        The part as simulated.
    error : str or None
        Why no grasp could be simulated (then every label is an error label).
    seconds : float
        Wall-clock time of the whole run.
    """

    labels: tuple[SimLabel, ...]
    settings: SimSettings
    contact: ContactModel
    shape: Any = field(repr=False)
    error: str | None
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """The top-level ``sim`` object of a labelled grasp file."""
        p = {} if self.shape is None else self.shape.to_dict()
        return {
            "settings": self.settings.to_dict(),
            "contact": {"mu": self.contact.mu, "torsion": self.contact.torsion,
                        "condim": self.contact.condim, "cone": "elliptic"},
            **p,
            "error": self.error,
            "held": sum(lab.held is True for lab in self.labels),
            "errors": sum(lab.failed_at == "error" for lab in self.labels),
            "seconds": self.seconds,
        }


def require_sim() -> None:
    """Refuse to simulate without the optional package (mujoco).

    Raises
    ------
    InputError
        Naming the missing package and the extra that installs it.
    """
    import importlib

    try:
        importlib.import_module("mujoco")
    except ImportError:
        raise InputError("simulation needs the package mujoco, which is not installed: pip "
                         "install 'synth[sim]'") from None


def check_mesh(file: GraspFile) -> None:
    """Refuse a grasp file whose mesh is missing or has changed since it was planned.

    Raises
    ------
    InputError
        Naming the grasp file, the mesh and what is wrong.
    """
    if not isinstance(file, GraspFile):
        raise InputError(f"file: expected a GraspFile (read_grasp_file), got "
                         f"{type(file).__name__}")
    path = file.mesh_path
    if path.is_dir():
        raise InputError(f"{file.path}: field mesh.path: {path} is a folder, not a mesh file "
                         "(give the mesh with --mesh)")
    if not path.is_file():
        raise InputError(f"{file.path}: field mesh.path: {path}: no such file (give the mesh "
                         "with --mesh)")
    if file.sha256 is not None:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        if digest != file.sha256:
            raise InputError(f"{file.path}: field mesh.sha256: {path} has changed since the "
                             f"grasps were planned (sha256 {digest[:12]}..., the file says "
                             f"{file.sha256[:12]}...)")


def load_planned_part(file: GraspFile) -> Any:
    """The part a grasp file was planned on: its mesh loaded with the plan's loader options.

    Raises
    ------
    InputError
        The mesh is missing or changed, or loads into a part of another size than the one
        planned (other loader options than the file records).
    """
    from synth.part import load_part

    check_mesh(file)
    part = load_part(file.mesh_path, **file.load)
    # the same file loaded the same way gives the same length; a hand-written file may give
    # it in full precision where the mesh stores float32 coordinates
    if abs(part.length - file.length) > 1e-6 * file.length + 4.0 * part.precision:
        raise InputError(f"{file.path}: field mesh.length: the mesh {file.mesh_path} loads into "
                         f"a part of size {part.length:.6g}, the grasps were planned on one of "
                         f"{file.length:.6g} (a different mesh, or other --units / --body)")
    return part


#: How far (a share of the part's size) a grasp file's contact may lie from the part's surface,
#: and its fingertip from one radius off it, before the grasp is taken for another part's.
CONTACT_RTOL = 1e-3


def misplaced(g: SimGrasp, part: Any) -> str | None:
    """Why a grasp's contacts are not on the part (a hand-edited file, another part's grasps),
    or None: each contact within ``CONTACT_RTOL`` of the part's size of its surface, its
    fingertip one tip radius from it on the outside (against the contact's inward normal)."""
    from synth.limits import MAX_COORDINATE

    tol = CONTACT_RTOL * part.length + 4.0 * part.surface_tolerance
    if not (np.abs(g.points) <= MAX_COORDINATE).all():
        return f"a contact's coordinates are above {MAX_COORDINATE:g} in size"
    off = part.surface_distance(g.points)
    j = int(np.argmax(off))
    if off[j] > tol:
        return (f"contact {j} is {off[j]:.3g} from the part's surface (at most {tol:.3g}): "
                "the grasp does not touch this part")
    owner = np.arange(len(g.points)) if g.contact_finger is None else g.contact_finger
    gap = g.tip_centers[owner] - g.points  # from each contact to its fingertip's centre
    wrong = (np.abs(np.linalg.norm(gap, axis=1) - g.tip_radius) > tol) | (
        np.einsum("ij,ij->i", gap, g.normals) > 0.0)
    if wrong.any():
        j = int(np.flatnonzero(wrong)[0])
        return (f"fingertip {int(owner[j])} is not one tip radius outside contact {j} against "
                "its normal (points, normals and fingers.tip_centers disagree)")
    return None


def balanced_preload(g: SimGrasp, center_mass: NDArray[np.float64], length: float,
                     mu: float, grip: float) -> NDArray[np.float64]:
    """The balanced hand's squeeze of one grasp: each finger's force in newtons.

    For a frictionless grasp with one contact per finger, the stiff hand's best preload
    (:func:`synth.scores.hold.stiff_hold_batch`) scaled so that the fingers hold the heaviest
    part they can in every orientation with no finger above ``grip``. Otherwise the most even
    internal squeeze (:func:`synth.scores.hold.internal_squeeze`) at half the grip force, its
    contacts' forces summed per finger; equal forces of half the grip when there is none.
    """
    from synth.scores.arguments import center_arg, length_arg
    from synth.scores.hold import finger_hold_batch, internal_squeeze

    if not isinstance(g, SimGrasp):
        raise InputError(f"g: expected a SimGrasp (read_grasp_file), got {type(g).__name__}")
    center_mass = center_arg(center_mass, name="center_mass")
    length = length_arg(length)
    grip = length_arg(grip, "grip")
    if isinstance(mu, bool) or not isinstance(mu, numbers.Real) or not 0 <= mu < float("inf"):
        raise InputError(f"mu: expected a finite number >= 0, got {mu!r}")
    f = len(g.tip_centers)
    owner = np.arange(len(g.points)) if g.contact_finger is None else g.contact_finger
    hold = finger_hold_batch(g.points[None], g.normals[None], center_mass, length, mu,
                             owner[None])
    spw = float(hold.squeeze_per_weight[0])
    if hold.model == "stiff" and np.isfinite(spw):
        return grip * hold.preload[0] / spw
    lam = internal_squeeze(g.points, g.normals, center_mass, length, mu)
    if lam is None:
        return np.full(f, 0.5 * grip)
    per = np.zeros((f, 3))
    np.add.at(per, owner, lam[:, None] * g.normals)
    force = np.linalg.norm(per, axis=1)
    return 0.5 * grip * force / max(float(force.max()), 1e-300)


def simulate_file(file: GraspFile, settings: SimSettings | None = None, *,
                  contact: ContactModel | None = None, part: Any = None,
                  progress: Callable[[int, int], None] | None = None) -> SimReport:
    """Simulate every grasp of a checked grasp file.

    Parameters
    ----------
    file : GraspFile
        From :func:`synth.sim.read_grasp_file`.
    settings : SimSettings, optional
        The hand and the disturbances (default :class:`SimSettings`).
    contact : ContactModel, optional
        Default: the grasps' own, frictionless or with the file's ``params.mu``.
    part : Part, optional
        The part the grasps were planned on (default: loaded again from the file's mesh with
        the recorded loader options, :func:`load_planned_part`).
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
    from synth.sim.protocol import run_refined
    from synth.sim.scene import build_scene
    from synth.sim.shape import part_shape

    if not isinstance(file, GraspFile):
        raise InputError(f"file: expected a GraspFile (read_grasp_file), got "
                         f"{type(file).__name__}")
    if settings is not None and not isinstance(settings, SimSettings):
        raise InputError(f"settings: expected SimSettings or None, got {type(settings).__name__}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress: expected a function of (done, total), got "
                         f"{type(progress).__name__}")
    t0 = time.perf_counter()
    st = settings or SimSettings()
    model = contact or ContactModel(file.mu)
    if not file.grasps:
        raise InputError(f"{file.path}: field grasps: no grasp to simulate")
    part = part if part is not None else load_planned_part(file)
    shape = part_shape(part)
    out: list[SimLabel] = []
    for i, g in enumerate(file.grasps):
        why = misplaced(g, part)
        if why is not None:  # not simulated: its fingers are not where its contacts say
            out.append(start_label(why))
            if progress is not None:
                progress(i + 1, len(file.grasps))
            continue
        try:
            preload = None if st.hand == "saturated" else balanced_preload(
                g, file.center_mass, file.length, model.mu, st.grip)
            run, scene = run_refined(partial(
                build_scene, shape, g.tip_centers, g.approach, g.tip_radius,
                length=file.length, center_mass=file.center_mass, volume=file.volume,
                contact=model, preload=preload), st)
            escape = predicted_escape(g.points, g.normals, model.mu, file.center_mass,
                                      file.length)
            out.append(label_run(run, scene, escape))
        except SimulationError as e:
            out.append(error_label(str(e)))
        if progress is not None:
            progress(i + 1, len(file.grasps))
    return SimReport(tuple(out), st, model, shape, None, time.perf_counter() - t0)


def labelled_document(file: GraspFile, report: SimReport) -> dict[str, Any]:
    """The grasp document with each grasp's ``sim`` label and the run's ``sim`` summary
    (``file`` may hold the document's first grasps only: the others are left without a
    label, an earlier one removed, so that the document's labels are all of this run)."""
    doc = copy.deepcopy(file.document)
    for g in doc["grasps"][len(report.labels):]:
        g.pop("sim", None)
    for g, lab in zip(doc["grasps"][: len(report.labels)], report.labels, strict=True):
        g["sim"] = lab.to_dict()
    doc["sim"] = report.to_dict()
    return doc
