"""Build the MuJoCo model of one point-finger grasp: the part on a free joint, one finger per
fingertip, every finger starting clear of the part.

Frame: the simulation's world is the hand's frame. For point fingers it is the part's frame
(the mesh file's axes), moved so that the part's centre of mass is at the origin and scaled by
``size / length`` (see :mod:`synth.sim.settings`): gravity along -z of the world is gravity
along -z of the file.

* The part is one body with a free joint, its frame at the centre of mass, its mass and
  inertia those of the part's closed bodies at the settings' density (given explicitly:
  MuJoCo would sum the overlapping convex pieces), one mesh geom per convex piece and per
  facet slab near the fingers (:mod:`synth.sim.shape`). A weld (the equality ``hold``) keeps it in
  place while the hand closes and squeezes, as a part rests where it is while fingers close on it;
  the protocol then lets go, and the part is held by the fingers alone.
* Each finger is a sphere of the planned tip radius on a slide joint along its approach,
  starting ``START_GAP`` tip radii back from its planned place along the approach (clear of
  the part: the planner checked the finger's body there), driven by a position servo of gain
  ``stiffness``, critically damped for the fingertip's mass, its force limited to the grip
  force. Its weight is compensated. Fingers collide with the part only.
* The controls (servo targets, metres along each slide) of the three stages the protocol
  (:mod:`synth.sim.protocol`) goes through: ``open`` (where the fingers start), ``touch``
  (the planned contact) and ``squeeze``, with the squeeze's target forces for the balanced
  hand (:mod:`synth.scores.hold`).
* Contacts use the grasp's own model on both geoms of each pair (:class:`ContactModel`), with
  a time constant of two steps, elliptic cones, friction as hard as the normal force
  (``impratio`` = ``IMPRATIO``) and the noslip solver (``SimSettings.noslip``): without it a
  squeezed part creeps about 2 degrees a second under its own weight.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, SimulationError
from synth.sim.contact import ContactModel
from synth.sim.settings import TRANSLATION_RTOL, SimSettings
from synth.sim.shape import PartShape, within

__all__ = ["Scene", "build_scene", "new_spec", "add_part", "compile_spec", "quiet_mujoco",
           "contact_params", "GRAVITY",
           "IMPRATIO", "START_GAP", "START_RTOL", "REACH_RTOL", "penetration_limit", "PART_BITS",
           "HAND_BITS"]

#: Standard gravity, m/s^2.
GRAVITY: float = 9.80665
#: MuJoCo's ratio of frictional to normal constraint impedance (elliptic cones).
IMPRATIO: float = 10.0
#: How far back along its approach a fingertip starts, in tip radii.
START_GAP: float = 0.5
#: How deep a finger may touch the part where it starts, as a fraction of its size (tip
#: radius, pad thickness): ten times the planner's penetration tolerance.
START_RTOL: float = 0.01
#: contype / conaffinity bits: the hand touches the part only.
PART_BITS, HAND_BITS = 1, 2


@dataclass(frozen=True)
class Scene:
    """A compiled MuJoCo model of one grasp, its stages' controls and what it is made of.

    Attributes
    ----------
    model : mujoco.MjModel
    part : int
        Body id of the part (its free joint's ``qpos`` are entries 0 to 6).
    actuators : int
        Number of actuators (point fingers, or 1 for a gripper's coupled jaws).
    scale : float
        Simulation metres per mesh unit.
    origin : (3,) float
        The mesh point at the centre of mass.
    frame : (3, 3) float
        The hand's axes in the mesh's frame (columns): a world vector ``v`` is ``frame @ v``
        in the mesh's frame.
    size : float
        The part's bounding-box diagonal in the simulation, m.
    mass, weight : float
        kg and N.
    inertia : (3,) float
        Principal moments of inertia, kg m^2.
    ctrl_open, ctrl_touch, ctrl_squeeze : (a,) float
        Servo targets where the fingers start, at the planned contact, and squeezing.
    preload : (a,) float or None
        The balanced hand's target finger forces, N (None: the squeeze's targets are final).
    grip : float
        Force limit of each finger (point fingers) or of the jaws, N.
    stroke : float
        How far the hand may let the part move elastically, m (added to the translation
        threshold).
    penetration_limit : (g,) float
        Per geom of the model, how deep a finger may sink into it before the solver is deemed
        lost, m (half the finger's size, and half the slab's depth for a facet slab); inf
        for the hand's own geoms.
    start_tolerance : float
        Deepest a finger may touch the part where it starts, m (a fingertip planned against a
        side wall grazes it by the planner's penetration tolerance).
    shake_gravity : (3,) float
        Unit direction of gravity during the shake, world frame.
    settings : SimSettings
    contact : ContactModel
    """

    model: Any = field(repr=False)
    part: int
    actuators: int
    scale: float
    origin: NDArray[np.float64] = field(repr=False)
    frame: NDArray[np.float64] = field(repr=False)
    size: float
    mass: float
    weight: float
    inertia: NDArray[np.float64] = field(repr=False)
    ctrl_open: NDArray[np.float64] = field(repr=False)
    ctrl_touch: NDArray[np.float64] = field(repr=False)
    ctrl_squeeze: NDArray[np.float64] = field(repr=False)
    preload: NDArray[np.float64] | None = field(repr=False)
    grip: float
    stroke: float
    penetration_limit: NDArray[np.float64] = field(repr=False)
    start_tolerance: float
    shake_gravity: NDArray[np.float64] = field(repr=False)
    settings: SimSettings = field(repr=False)
    contact: ContactModel = field(repr=False)

    @property
    def translation_limit(self) -> float:
        """Displacement of the centre of mass past which the part has moved, m."""
        return TRANSLATION_RTOL * self.size + self.stroke

    @property
    def rotation_limit(self) -> float:
        """Rotation past which the part has moved, rad."""
        return 2.0 * self.translation_limit / self.size


def new_spec(settings: SimSettings) -> Any:
    """An empty MuJoCo spec with the options every synth scene uses."""
    import mujoco

    spec = mujoco.MjSpec()
    o = spec.option
    o.timestep = settings.dt
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    o.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    o.impratio = IMPRATIO
    o.iterations = settings.iterations
    o.noslip_iterations = settings.noslip
    o.gravity = [0.0, 0.0, 0.0]
    return spec


def contact_params(settings: SimSettings, contact: ContactModel) -> dict[str, Any]:
    """The geom attributes of both sides of every finger-part contact."""
    return {"condim": contact.condim, "friction": contact.friction,
            "solref": [2.0 * settings.dt, 1.0]}


def add_part(spec: Any, shape: PartShape, pieces: list[NDArray[np.float64]], *,
             center_mass: NDArray[np.float64],
             volume: float, scale: float, rotation: NDArray[np.float64] | None = None,
             position: NDArray[np.float64] | None = None, density: float,
             common: dict[str, Any]) -> Any:
    """Add the part as a free body whose frame is its centre of mass, welded to the world by
    the equality ``"hold"`` until the protocol lets go of it.

    Parameters
    ----------
    spec : mujoco.MjSpec
    shape : PartShape
        The part's mass properties.
    pieces : list of (m, 3) float
        The convex pieces to collide (:meth:`PartShape.near`).
    center_mass : (3,) float
        Mesh coordinates.
    volume : float
        The part's volume, mesh units cubed (0: the pieces' mass properties).
    scale : float
        Metres per mesh unit.
    rotation : (3, 3) float, optional
        World axes in the mesh's frame (columns); default the identity.
    position : (3,) float, optional
        Where the centre of mass is in the world, m (default the origin).
    density : float
        kg/m^3.
    common : dict
        Contact attributes (:func:`contact_params`).

    Returns
    -------
    mujoco.MjsBody
    """
    import mujoco

    R = np.eye(3) if rotation is None else np.asarray(rotation, float)
    com = np.asarray(center_mass, float)
    vol = volume if volume > 0 else shape.volume
    mass = density * vol * scale**3
    d = shape.center - com
    inertia = shape.inertia + shape.volume * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    inertia = R.T @ inertia @ R * (vol / shape.volume) * density * scale**5
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(axes).ravel())
    body = spec.worldbody.add_body(name="part", pos=list(np.zeros(3) if position is None
                                                         else np.asarray(position, float)))
    body.add_freejoint()
    # held in place while the hand closes and squeezes; the protocol lets go of it after
    hold = spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, name1="part", name2="world",
                             objtype=mujoco.mjtObj.mjOBJ_BODY, name="hold")
    hold.solref = common["solref"]
    body.explicitinertial = True
    body.mass = mass
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = quat.tolist()
    size = vol ** (1.0 / 3.0) * scale
    body.inertia = np.maximum(moments, 1e-12 * mass * size**2).tolist()
    for i, v in enumerate(pieces):
        # the body's inertia is given: a mesh's own (of a thin slab, too small for MuJoCo's
        # volume check) is taken as a shell's and never used
        spec.add_mesh(name=f"piece{i}", uservert=(((v - com) @ R) * scale).ravel().tolist(),
                      inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"piece{i}",
                      contype=PART_BITS, conaffinity=HAND_BITS, **common)
    return body


@contextmanager
def quiet_mujoco() -> Iterator[None]:
    """MuJoCo's warnings go nowhere while this lasts (by default it prints them and appends
    them to ``MUJOCO_LOG.TXT`` in the current folder); synth reads them from MuJoCo's
    counters instead."""
    import mujoco

    saved = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(saved)


def penetration_limit(model: Any, depths: NDArray[np.float64], scale: float,
                      size: float) -> NDArray[np.float64]:
    """Per geom, how deep a finger of ``size`` (a tip radius, a pad's thickness; m) may sink
    into it before the simulation is stopped as diverged: half its size, and half a slab's
    depth (``depths``, mesh units, per part geom in order; deeper, a finger would push
    through it). The part's geoms are the first of the model."""
    out = np.full(model.ngeom, np.inf)
    out[: len(depths)] = np.minimum(0.5 * size, 0.5 * np.asarray(depths) * scale)
    return out


def compile_spec(spec: Any) -> Any:
    """The compiled model; MuJoCo's refusal as :class:`~synth.errors.SimulationError`."""
    try:
        with quiet_mujoco():
            return spec.compile()
    except ValueError as e:
        reason = " ".join(str(e).split())
        raise SimulationError(f"MuJoCo cannot load the scene: {reason}") from e


#: How far the part may move before the protocol calls it moved, with room to spare, as a
#: fraction of its size: facets farther than this from a finger are left out of its scene.
REACH_RTOL: float = 0.03


def build_scene(shape: PartShape, tip_centers: NDArray[np.float64],
                approach: NDArray[np.float64], tip_radius: float, *, length: float,
                center_mass: NDArray[np.float64], volume: float, settings: SimSettings,
                contact: ContactModel, preload: NDArray[np.float64] | None = None) -> Scene:
    """Compile the model of one point-finger grasp of a part.

    Parameters
    ----------
    shape : PartShape
        The part's collision shape (:func:`synth.sim.part_shape`).
    tip_centers : (f, 3) float
        Planned fingertip centres, mesh coordinates.
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
    preload : (f,) float, optional
        The balanced hand's squeeze, each finger's force in newtons, at most the grip force
        (:func:`synth.sim.balanced_preload`); required for ``settings.hand == "balanced"``.

    Returns
    -------
    Scene

    Raises
    ------
    SimulationError
        MuJoCo cannot compile the pieces (its reason is in the message).
    """
    import mujoco

    from synth.scores.arguments import center_arg, length_arg

    length = length_arg(length)
    tip_radius = length_arg(tip_radius, "tip_radius")
    com = center_arg(center_mass, name="center_mass")
    if not isinstance(shape, PartShape) or not isinstance(settings, SimSettings) or not \
            isinstance(contact, ContactModel):
        raise InputError("build_scene: expected a PartShape (part_shape), SimSettings and a "
                         f"ContactModel, got {type(shape).__name__}, {type(settings).__name__} "
                         f"and {type(contact).__name__}")
    s = settings.size / length
    spec = new_spec(settings)
    common = contact_params(settings, contact)
    C = np.asarray(tip_centers, float)
    A = np.asarray(approach, float)
    reach = (1.0 + START_GAP) * tip_radius + REACH_RTOL * length
    pieces, depths = shape.near(within(C, reach))
    add_part(spec, shape, pieces, center_mass=com, volume=volume, scale=s,
             density=settings.density, common=common)
    radius = tip_radius * s
    gap = START_GAP * radius
    kv = 2.0 * np.sqrt(settings.stiffness * settings.finger_mass)
    for j, (c, a) in enumerate(zip(C, A, strict=True)):
        body = spec.worldbody.add_body(name=f"finger{j}", pos=((c - com) * s + gap * a).tolist())
        body.gravcomp = 1.0
        body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=(-a).tolist(), name=f"slide{j}")
        body.add_geom(name=f"fingertip {j}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                      size=[radius, 0.0, 0.0],
                      mass=settings.finger_mass, contype=HAND_BITS, conaffinity=PART_BITS,
                      **common)
        act = spec.add_actuator(name=f"servo{j}", target=f"slide{j}",
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=settings.stiffness, kv=kv)
        act.forcelimited = True
        act.forcerange = [-settings.grip, settings.grip]
    model = compile_spec(spec)
    f = len(C)
    touch = np.full(f, gap)
    target: NDArray[np.float64] | None = None
    if settings.hand == "saturated":
        squeeze = touch + settings.stroke
    else:
        if preload is None or len(preload) != f:
            raise SimulationError("the balanced hand needs the grasp's squeeze, one force per "
                                  "finger")
        target = np.clip(np.asarray(preload, float), 0.0, settings.grip)
        squeeze = touch + target / settings.stiffness
    return Scene(model, 1, f, s, com, np.eye(3), settings.size, float(model.body_mass[1]),
                 float(model.body_mass[1]) * GRAVITY, np.asarray(model.body_inertia[1]),
                 np.zeros(f), touch, squeeze, target, settings.grip, settings.stroke,
                 penetration_limit(model, depths, s, radius), START_RTOL * radius,
                 np.array([0.0, 0.0, -1.0]), settings, contact)
