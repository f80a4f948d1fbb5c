"""Gripper grasps in MuJoCo: the gripper's pads, coupled, at its rated force.

A ``synth.gripper_grasps`` grasp is simulated with the hand as the gripper is built, not with
the scorer's model of it: the world is the gripper's frame (ACRONYM's: approach +z, fingers
closing along x), and the part sits where the grasp's pose puts it, at its real size (gripper
plans know the part's unit). Each finger is a box pad of the gripper's pad size (a quarter of
its smaller side thick) on a slide joint along x, at the height the finger reaches at the
grasp's width (a Robotiq linkage's rise, ``Gripper.rise``). The two fingers are coupled as on
the real hand: an equality keeps them symmetric about the hand's axis, and one position servo
drives both through a tendon, its force limited to the gripper's rated grip force, so each pad
presses with that force once the jaws close (the servo aims at a closed hand and saturates).
The pads start ``JAW_GAP`` of the width clear on each side and close onto the part; the
contacts are the ones MuJoCo finds between the boxes and the part's convex pieces (several per
pad on a face), with the plan's ``mu`` and torsion (``condim`` 4). The palm and the finger
bodies are not in the scene: the planner checked them against the part.

Mass: the plan's ``--mass`` when it had one, else its ``--density``, else the simulation's
``density``, times the part's volume. Gravity during the shake is along the approach (+z of
the hand: a gripper picking from above).
"""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, SimulationError
from synth.sim.contact import ContactModel
from synth.sim.scene import (
    GRAVITY,
    HAND_BITS,
    PART_BITS,
    REACH_RTOL,
    START_RTOL,
    Scene,
    add_part,
    compile_spec,
    contact_params,
    new_spec,
    penetration_limit,
)
from synth.sim.settings import SimSettings
from synth.sim.shape import PartShape

__all__ = ["JAW_GAP", "PAD_THICKNESS", "build_jaw_scene", "simulate_jaw_document",
           "jaw_mass"]

#: How far each pad starts from its contact, as a fraction of the grasp's width (at least a
#: tenth of the pad's thickness).
JAW_GAP: float = 0.05
#: Pad thickness, as a fraction of the pad's smaller side.
PAD_THICKNESS: float = 0.25


def jaw_mass(doc: dict[str, Any], part: Any, metres: float, settings: SimSettings) -> float:
    """The simulated part's mass, kg: the plan's mass, else its density, else the
    simulation's, times the part's volume (``metres`` per mesh unit)."""
    model, params = doc.get("model", {}), doc.get("params", {})
    mass = model.get("mass") if isinstance(model, dict) else None
    if isinstance(mass, (int, float)) and not isinstance(mass, bool) and mass > 0:
        return float(mass)
    density = params.get("density") if isinstance(params, dict) else None
    if not (isinstance(density, (int, float)) and not isinstance(density, bool)
            and density > 0):
        density = settings.density
    volume = float(part.volume) if part.volume > 0 else 0.0
    if volume <= 0:
        import trimesh

        volume = float(trimesh.convex.convex_hull(part.mesh.vertices).volume)
    return float(density) * volume * metres**3


def _between_pads(R: NDArray[np.float64], t: NDArray[np.float64], half: NDArray[np.float64],
                  reach: float):  # type: ignore[no-untyped-def]
    """A facet selector for :meth:`PartShape.near`: triangles (mesh frame) whose bounding box
    in the hand's frame meets the box ``[-half, half]`` grown by ``reach``."""
    def inside(tri: NDArray[np.float64]) -> NDArray[np.bool_]:
        h = (tri - t) @ R  # into the hand's frame
        lo, hi = h.min(axis=1), h.max(axis=1)
        return np.all((hi >= -half - reach) & (lo <= half + reach), axis=1)
    return inside


def build_jaw_scene(shape: PartShape, part: Any, pose: NDArray[np.float64], width: float,
                    gripper: Any, metres: float, mass: float, settings: SimSettings,
                    contact: ContactModel) -> Scene:
    """Compile the model of one gripper grasp.

    Parameters
    ----------
    shape : PartShape
        The part's collision shape (:func:`synth.sim.part_shape`).
    part : Part
        The part planned on (centre of mass, volume, size).
    pose : (4, 4) float
        The gripper's pose in the part's frame, mesh units (``grasps[i].pose``).
    width : float
        Distance between the pads at the grasp, mesh units.
    gripper : synth.fingers.Gripper
        As described (metres).
    metres : float
        Metres per mesh unit.
    mass : float
        kg.
    settings : SimSettings
    contact : ContactModel
        Its torsion in metres.

    Returns
    -------
    Scene
    """
    import mujoco

    T = np.asarray(pose, float)
    R, t = T[:3, :3], T[:3, 3]
    com = np.asarray(part.center_mass, float)
    spec = new_spec(settings)
    common = contact_params(settings, contact)
    volume = float(part.volume) if part.volume > 0 else 0.0
    w = float(width) * metres
    pad_w, pad_h = (float(x) for x in gripper.pad_size)
    yc, zc = (float(x) for x in gripper.pad_center)
    zc += float(gripper.rise(min(w, gripper.max_opening)))
    thick = PAD_THICKNESS * min(pad_w, pad_h)
    gap = max(JAW_GAP * w, 0.1 * thick)
    # the facets the pads can reach: the box they sweep, in mesh units, grown as for fingers
    half = np.array([0.5 * w + gap + thick, abs(yc) + 0.5 * pad_w, 0.5 * pad_h]) / metres
    centre = np.array([0.0, 0.0, zc / metres])
    pieces, depths = shape.near(_between_pads(R, t + R @ centre, half,
                                              REACH_RTOL * part.length))
    density = mass / ((volume if volume > 0 else shape.volume) * metres**3)
    add_part(spec, shape, pieces, center_mass=com, volume=volume, scale=metres, rotation=R,
             position=R.T @ (com - t) * metres, density=density, common=common)
    pad_half = [0.5 * thick, 0.5 * pad_w, 0.5 * pad_h]
    kv = 2.0 * np.sqrt(settings.stiffness * settings.finger_mass)
    for j, sign in enumerate((1.0, -1.0)):
        body = spec.worldbody.add_body(name=f"finger{j}")
        body.gravcomp = 1.0
        body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[-sign, 0.0, 0.0],
                       name=f"slide{j}")
        body.add_geom(name=f"pad {j}", type=mujoco.mjtGeom.mjGEOM_BOX, size=pad_half,
                      pos=[sign * (0.5 * w + gap + 0.5 * thick), sign * yc, zc],
                      mass=settings.finger_mass, contype=HAND_BITS, conaffinity=PART_BITS,
                      **common)
    eq = spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1="slide0", name2="slide1")
    eq.data[:5] = [0.0, 1.0, 0.0, 0.0, 0.0]
    eq.solref = [2.0 * settings.dt, 1.0]  # as stiff as the contacts (MuJoCo's default 0.02 s
    # lets fingers of 20 g drift apart by centimetres under the part's weight)
    tendon = spec.add_tendon(name="jaws")
    tendon.wrap_joint("slide0", 1.0)
    tendon.wrap_joint("slide1", 1.0)
    act = spec.add_actuator(name="grip", target="jaws", trntype=mujoco.mjtTrn.mjTRN_TENDON)
    act.set_to_position(kp=settings.stiffness, kv=kv)
    act.forcelimited = True
    grip = float(gripper.grip_force)
    act.forcerange = [-grip, grip]
    model = compile_spec(spec)
    # tendon length is the sum of both slides: touching at 2 gap, closed at 2 gap + w
    return Scene(model, 1, 1, metres, com, R, float(part.length) * metres, mass, mass * GRAVITY,
                 np.asarray(model.body_inertia[1]), np.zeros(1), np.array([2.0 * gap]),
                 np.array([2.0 * gap + w]), None, grip, 0.0,
                 penetration_limit(model, depths, metres, thick), START_RTOL * thick,
                 np.array([0.0, 0.0, 1.0]), settings, contact)


def simulate_jaw_document(doc: dict[str, Any], part: Any, settings: SimSettings | None = None,
                          mu: float | None = None, progress: Any = None) -> dict[str, Any]:
    """Simulate every grasp of a gripper plan's document; the document with ``sim`` labels.

    Parameters
    ----------
    doc : dict
        A checked ``synth.gripper_grasps`` document (:func:`synth.sim.check_jaw_document`)
        with at least one grasp.
    part : Part
        The part it was planned on.
    settings : SimSettings, optional
    mu : float, optional
        Simulate with this friction coefficient instead of the plan's ``model.mu`` (the
        document keeps its own; the run's ``contact`` says what was simulated).
    progress : callable, optional
        Called with (grasps done, grasps) after each grasp.

    Returns
    -------
    dict
        A copy of ``doc`` with each grasp's ``sim`` label and the run's ``sim`` summary.
    """
    import copy

    from synth.fingers.gripper import load_gripper
    from synth.formats.arrays import unit_metres
    from synth.sim.document import jaw_gripper_source
    from synth.sim.label import SimLabel, error_label, label_run
    from synth.sim.protocol import run_refined
    from synth.sim.shape import part_shape
    from synth.sim.simulate import SimReport

    t0 = time.perf_counter()
    st = settings or SimSettings()
    metres = unit_metres(doc["mesh"]["units"], "mesh", "units")
    source = jaw_gripper_source(doc)
    if not isinstance(source, str):
        raise InputError("field gripper.source: expected the gripper's name or description "
                         "file")
    gripper = load_gripper(source if not Path(source).suffix else Path(source))
    model = doc["model"]
    torsion = float(model.get("torsion") or 0.0) * metres
    contact = ContactModel(float(model["mu"]) if mu is None else mu, torsion)
    mass = jaw_mass(doc, part, metres, st)
    labels: list[SimLabel] = []
    shape = part_shape(part)
    for i, g in enumerate(doc["grasps"]):
        try:
            run, scene = run_refined(partial(
                build_jaw_scene, shape, part, np.asarray(g["pose"], float), float(g["width"]),
                gripper, metres, mass, contact=contact), st)
            labels.append(label_run(run, scene, None))
        except SimulationError as e:
            labels.append(error_label(str(e)))
        if progress is not None:
            progress(i + 1, len(doc["grasps"]))
    report = SimReport(tuple(labels), st, contact, shape, None, time.perf_counter() - t0)
    out = copy.deepcopy(doc)
    for g, lab in zip(out["grasps"], labels, strict=True):
        g["sim"] = lab.to_dict()
    out["sim"] = {**report.to_dict(), "hand": f"{gripper.title}: pads {gripper.pad_size[0]:g} x "
                  f"{gripper.pad_size[1]:g} m, coupled, rated force {gripper.grip_force:g} N",
                  "mass": mass}
    return out
