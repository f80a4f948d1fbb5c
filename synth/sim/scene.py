"""Build the MuJoCo model of one grasp: the part on a free joint, one finger per fingertip.

Frame: the simulation's world is the mesh file's frame, moved so that the part's centre of
mass is at the origin and scaled by ``size / length`` (see :mod:`synth.sim.settings`); axes
keep their directions, so gravity is -z of the file and a push along +x in the simulation is
a push along +x of the file.

* The part is one body with a free joint, its frame at the centre of mass, its mass and
  inertia those of the file's closed bodies at the settings' density (given explicitly:
  MuJoCo would sum the overlapping convex pieces), one mesh geom per convex piece.
* Each finger is a sphere of the planned tip radius on a slide joint along its approach
  (``-approach``, into the part), starting at the planned tip centre, driven by a position
  servo of gain ``stiffness``, critically damped for the fingertip's mass, whose force is
  limited to the grip force (``forcerange``). Its weight is compensated (``gravcomp``).
  Fingers collide with the part only.
* Contacts use the grasp's own model on both geoms of each pair (:class:`ContactModel`),
  with a time constant of two steps, the stiffest MuJoCo allows. Friction is made as hard as
  the normal force (``impratio`` = ``IMPRATIO``): with MuJoCo's default of 1 a frictional
  grasp creeps under a steady load (measured: a 3-finger cube grasp at mu = 0.8 slid 2% of
  its size within 1.5 s under its own weight; with 10 it holds).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import MeshError
from synth.sim.contact import ContactModel
from synth.sim.pieces import ConvexPieces
from synth.sim.settings import SimSettings

__all__ = ["Scene", "build_scene", "GRAVITY", "IMPRATIO"]

#: Standard gravity, m/s^2.
GRAVITY: float = 9.81
#: MuJoCo's ratio of frictional to normal constraint impedance (elliptic cones).
IMPRATIO: float = 10.0

_PART_BITS, _FINGER_BITS = 1, 2  # contype / conaffinity: fingers touch the part only


@dataclass(frozen=True)
class Scene:
    """A compiled MuJoCo model of one grasp and what it is made of.

    Attributes
    ----------
    model : mujoco.MjModel
    part : int
        Body id of the part (its free joint's ``qpos`` are ``model.nq`` entries 0 to 6).
    fingers : int
        Number of fingers (actuators ``0 .. fingers - 1``).
    scale : float
        Simulation metres per mesh unit.
    origin : (3,) float
        The mesh point at the simulation's origin (the part's centre of mass).
    mass : float
        The part's mass, kg.
    weight : float
        Its weight, N.
    inertia : (3,) float
        Its principal moments of inertia, kg m^2.
    tip_radius : float
        Fingertip radius, m.
    settings : SimSettings
    contact : ContactModel
    """

    model: Any = field(repr=False)
    part: int
    fingers: int
    scale: float
    origin: NDArray[np.float64] = field(repr=False)
    mass: float
    weight: float
    inertia: NDArray[np.float64] = field(repr=False)
    tip_radius: float
    settings: SimSettings = field(repr=False)
    contact: ContactModel = field(repr=False)


def build_scene(pieces: ConvexPieces, tip_centers: NDArray[np.float64],
                approach: NDArray[np.float64], tip_radius: float, *, length: float,
                center_mass: NDArray[np.float64], volume: float, settings: SimSettings,
                contact: ContactModel, mesh_name: str = "<mesh>") -> Scene:
    """Compile the model of one grasp of a part.

    Parameters
    ----------
    pieces : ConvexPieces
        The part's convex pieces (:func:`synth.sim.convex_pieces`).
    tip_centers : (f, 3) float
        Fingertip centres, mesh coordinates.
    approach : (f, 3) float
        Unit approach directions, away from the part.
    tip_radius : float
        Mesh units.
    length : float
        The part's bounding-box diagonal, mesh units (scaled to ``settings.size``).
    center_mass : (3,) float
        The part's centre of mass, mesh coordinates.
    volume : float
        Volume of its closed bodies, mesh units cubed (0: use the pieces' mass properties).
    settings : SimSettings
    contact : ContactModel
    mesh_name : str
        The mesh file, for messages.

    Returns
    -------
    Scene

    Raises
    ------
    MeshError
        MuJoCo cannot compile the pieces (its reason is in the message).
    """
    import mujoco

    s = settings.size / length
    com = np.asarray(center_mass, float)
    spec = mujoco.MjSpec()
    spec.option.timestep = settings.dt
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    solref = [2.0 * settings.dt, 1.0]
    common = {"condim": contact.condim, "friction": contact.friction, "solref": solref}

    part = spec.worldbody.add_body(name="part")
    part.add_freejoint()
    vol = volume if volume > 0 else pieces.volume
    mass = settings.density * vol * s**3
    # inertia of the pieces' closed bodies, moved to the file's centre of mass and scaled to
    # its volume (the bodies may overlap; the file's volume is that of their union)
    d = pieces.center - com
    inertia = pieces.inertia + pieces.volume * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    inertia = inertia * (vol / pieces.volume) * settings.density * s**5
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(axes).ravel())
    part.explicitinertial = True
    part.mass = mass
    part.ipos = [0.0, 0.0, 0.0]
    part.iquat = quat.tolist()
    part.inertia = np.maximum(moments, 1e-12 * mass * settings.size**2).tolist()
    for i, v in enumerate(pieces.pieces):
        spec.add_mesh(name=f"piece{i}", uservert=((v - com) * s).ravel().tolist())
        part.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"piece{i}",
                      contype=_PART_BITS, conaffinity=_FINGER_BITS, **common)

    radius = tip_radius * s
    kv = 2.0 * np.sqrt(settings.stiffness * settings.finger_mass)
    for j, (c, a) in enumerate(zip(np.asarray(tip_centers, float),
                                   np.asarray(approach, float))):
        body = spec.worldbody.add_body(name=f"finger{j}", pos=((c - com) * s).tolist())
        body.gravcomp = 1.0
        body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=(-a).tolist(),
                       name=f"slide{j}")
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0.0, 0.0],
                      mass=settings.finger_mass, contype=_FINGER_BITS,
                      conaffinity=_PART_BITS, **common)
        act = spec.add_actuator(name=f"servo{j}", target=f"slide{j}",
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=settings.stiffness, kv=kv)
        act.forcelimited = True
        act.forcerange = [-settings.grip, settings.grip]
    try:
        model = spec.compile()
    except ValueError as e:
        reason = " ".join(str(e).split())
        raise MeshError(f"{mesh_name}: MuJoCo cannot load its convex pieces: {reason}") from e
    return Scene(model, 1, len(tip_centers), s, com, float(model.body_mass[1]),
                 float(model.body_mass[1]) * GRAVITY, np.asarray(model.body_inertia[1]),
                 radius, settings, contact)
