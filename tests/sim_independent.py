"""An independent simulation of synth's grasps. It shares no code with synth.

It reads a grasp file (``synth.grasps`` or ``synth.gripper_grasps``) and the mesh file itself,
writes an MJCF scene as text, and runs its own protocol: close onto the part, squeeze, the
part's weight along +-x, +-y, +-z of the hand for ``HOLD_S`` each from the held state, then a
shake along x, y and z under gravity (-z of the part for point fingers, the approach for a
gripper). The part is held when its centre stays within ``MOVE_RTOL`` of its size (plus the
fingers' elastic travel) and it turns less than that length over half its size.

* The part: the mesh loaded by trimesh with its own vertex merging (so split OBJ seams are
  welded), split into connected pieces; a closed convex piece is used as it is; of any other,
  every triangle within ``NEAR_RTOL`` of the part's size of a finger becomes a prism
  ``SLAB_RTOL`` deep into the part (one MuJoCo mesh per triangle; not a sliver thinner than
  ``SLIVER_RTOL`` of that depth, which its neighbours cover). Mass from the file's volume
  at ``DENSITY``, inertia of the closed pieces.
* Point fingers: the part scaled to a 0.1 m diagonal; each finger a sphere of the planned
  radius on a slide joint along its approach, starting half a radius back, a position servo of
  ``STIFF`` N/m limited to ``GRIP`` N. They squeeze with the most even internal forces that
  keep every finger within the grip while the weight turns in every direction (the least-norm
  response ``pinv(W)`` of equal-stiffness fingers, solved here with numpy and scipy), and hold
  their positions after one correction towards those forces.
* A gripper: the part at its real size posed in the gripper frame; two box pads of the
  description's pad size on coupled slide joints, one servo on a tendon at the rated force.

``simulate(grasp_file, mesh_file)`` returns one ``held`` boolean per grasp.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import trimesh
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

SIZE = 0.1  # m, point-finger parts
DENSITY = 1000.0
GRIP = 10.0  # N per point finger
STIFF = 1e5  # N/m
TIP_MASS = 0.02  # kg
DT = 2e-4
MOVE_RTOL = 0.02
HOLD_S = 0.5
G = 9.80665
NEAR_RTOL = 0.04
SLAB_RTOL = 0.004
SLIVER_RTOL = 1e-4  # of the slab depth: thinner triangles get no prism
GRIPPERS = Path(__file__).resolve().parents[1] / "synth" / "fingers" / "grippers"


def _bodies(mesh_path: Path) -> tuple[list[np.ndarray], np.ndarray]:
    """Vertices of the closed convex pieces, and the triangles (t, 3, 3) of the others.

    Convex: trimesh's test, which looks across edges only, and qhull's hull holding no more
    than 1e-4 more volume (a fine tessellation of a dented body passes the first; the
    corpus's convex pieces are within 8e-6 of their hulls)."""
    loaded = trimesh.load(mesh_path, force="mesh", process=True)
    loaded.merge_vertices()
    convex, tris = [], []
    for body in loaded.split(only_watertight=False):
        if body.is_watertight and body.is_convex and \
                _hull_volume(body.vertices) <= body.volume * (1.0 + 1e-4):
            convex.append(np.asarray(body.vertices))
        else:
            tris.append(np.asarray(body.triangles))
    return convex, (np.concatenate(tris) if tris else np.zeros((0, 3, 3)))


def _hull_volume(vertices: np.ndarray) -> float:
    """qhull's hull volume; inf for a flat piece, which has none (a closed sliver of a CAD
    file: its triangles are then taken one by one)."""
    try:
        return float(ConvexHull(vertices).volume)
    except QhullError:
        return math.inf


def _pieces(convex: list[np.ndarray], tris: np.ndarray, near: np.ndarray, reach: float,
            depth: float) -> list[np.ndarray]:
    """The convex pieces, and a prism per triangle that comes within ``reach`` of a point of
    ``near``."""
    out = list(convex)
    for t in tris:
        c = t.mean(axis=0)
        if np.min(np.linalg.norm(near - c, axis=1)) > reach + np.max(np.linalg.norm(t - c, axis=1)):
            continue
        n = np.cross(t[1] - t[0], t[2] - t[0])
        longest = np.max(np.linalg.norm(t - np.roll(t, 1, axis=0), axis=1))
        if np.linalg.norm(n) <= SLIVER_RTOL * depth * longest:
            # a sliver (a float32 CAD file has some 1e-8 of the size thin): its prism would be
            # flat, which MuJoCo refuses, and its neighbours cover it to within its height
            continue
        n /= np.linalg.norm(n)
        out.append(np.vstack([t, t - depth * n]))
    return out


def _weighed(loaded: trimesh.Trimesh) -> list[trimesh.Trimesh]:
    """The closed pieces that have a volume (a closed sliver of a CAD file has none, and no
    centre of mass: it weighs nothing)."""
    return [b for b in loaded.split(only_watertight=True)
            if b.volume > 0 and np.isfinite(b.center_mass).all()]


def _closed_inertia(mesh_path: Path, com: np.ndarray) -> np.ndarray:
    """Inertia of the closed pieces about ``com``, per unit density (of the hull of every
    vertex when no piece is closed)."""
    loaded = trimesh.load(mesh_path, force="mesh", process=True)
    loaded.merge_vertices()
    bodies = _weighed(loaded) or [loaded.convex_hull]
    inertia = np.zeros((3, 3))
    for b in bodies:
        d = b.center_mass - com
        inertia += b.moment_inertia + b.volume * (d @ d * np.eye(3) - np.outer(d, d))
    return inertia


def _fmt(a) -> str:
    return " ".join(f"{x:.9g}" for x in np.ravel(a))


def _part_xml(pieces, com, R, pos, scale, mass, inertia, condim, friction, solref
              ) -> tuple[str, str]:
    assets, geoms = [], []
    for i, v in enumerate(pieces):
        assets.append(f'<mesh name="m{i}" inertia="shell" '
                      f'vertex="{_fmt(((v - com) @ R) * scale)}"/>')
        geoms.append(f'<geom type="mesh" mesh="m{i}" contype="1" conaffinity="2" '
                     f'condim="{condim}" friction="{_fmt(friction)}" solref="{_fmt(solref)}"/>')
    J = R.T @ inertia @ R
    full = f"{J[0, 0]:.9g} {J[1, 1]:.9g} {J[2, 2]:.9g} {J[0, 1]:.9g} {J[0, 2]:.9g} {J[1, 2]:.9g}"
    body = (f'<body name="part" pos="{_fmt(pos)}"><freejoint/>'
            f'<inertial pos="0 0 0" mass="{mass:.9g}" fullinertia="{full}"/>'
            + "".join(geoms) + "</body>")
    return "".join(assets), body


def _preload(P, N, com) -> np.ndarray:
    W = np.vstack([N.T, np.cross(P - com, N).T])
    A = np.linalg.pinv(W)[:, :3]
    r = np.linalg.norm(A, axis=1)
    Z = np.linalg.svd(W)[2][6:].T
    k, n = Z.shape
    res = linprog(np.r_[np.zeros(n), 1.0],
                  A_ub=np.block([[-Z, np.zeros((k, 1))], [Z, -np.ones((k, 1))]]),
                  b_ub=np.r_[-r, -r], bounds=[(None, None)] * (n + 1), method="highs")
    if res.status != 0:
        return np.full(len(P), 0.5)
    p = Z @ res.x[:n]
    return p / res.x[-1]  # forces at a grip of 1


def _friction_preload(P, N, com, mu) -> np.ndarray:
    k = len(P)
    cols = []
    for p, n in zip(P, N, strict=True):
        t = np.cross(n, [1, 0, 0] if abs(n[0]) < 0.9 else [0, 1, 0])
        t /= np.linalg.norm(t)
        b = np.cross(n, t)
        for a in np.linspace(0, 2 * np.pi, 8, endpoint=False):
            f = n + mu * (math.cos(a) * t + math.sin(a) * b)
            cols.append(np.r_[f, np.cross(p - com, f)])
    Gm = np.array(cols).T
    S = np.kron(np.eye(k), np.ones(8))
    m = Gm.shape[1]
    res = linprog(np.r_[np.zeros(m), -1.0],
                  A_ub=np.block([[-S, np.ones((k, 1))], [S, np.zeros((k, 1))]]),
                  b_ub=np.r_[np.zeros(k), np.ones(k)], A_eq=np.hstack([Gm, np.zeros((6, 1))]),
                  b_eq=np.zeros(6), bounds=[(0, None)] * (m + 1), method="highs")
    if res.status != 0 or res.x[-1] <= 1e-9:
        return np.full(k, 0.5)
    f = S @ res.x[:m]
    return 0.5 * f / f.max()


def _run(xml: str, ctrl_touch, ctrl_squeeze, target, size, slack, down, shake=1.0) -> bool:
    import mujoco

    mujoco.set_mju_user_warning(lambda text: None)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    m.opt.gravity[:] = 0
    mujoco.mj_forward(m, d)
    x0, q0 = d.qpos[:3].copy(), d.qpos[3:7].copy()
    lim = MOVE_RTOL * size + slack

    def moved(x_ref, q_ref) -> bool:
        v = np.zeros(3)
        mujoco.mju_subQuat(v, d.qpos[3:7], q_ref)
        return bool(np.linalg.norm(d.qpos[:3] - x_ref) > lim or np.linalg.norm(v) * size / 2 > lim
                    or not np.isfinite(d.qpos).all())

    def steps(seconds, each):
        n = int(round(seconds / DT))
        for i in range(n):
            each((i + 1) / n)
            mujoco.mj_step(m, d)
        return n

    steps(0.1, lambda f: d.ctrl.__setitem__(slice(None), min(1, 2 * f) * ctrl_touch))
    steps(0.25, lambda f: d.ctrl.__setitem__(
        slice(None), ctrl_touch + min(1, 2.5 * f) * (ctrl_squeeze - ctrl_touch)))
    if target is not None:
        d.ctrl[:] = d.ctrl + (target - np.abs(d.actuator_force)) / STIFF
        steps(0.1, lambda f: None)
    if moved(x0, q0):
        return False
    xh, qh = d.qpos[:3].copy(), d.qpos[3:7].copy()
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    for e in np.vstack([np.eye(3), -np.eye(3)]):
        mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
        steps(0.6, lambda f, e=e: m.opt.gravity.__setitem__(slice(None), min(1, 6 * f) * G * e))
        if moved(xh, qh):
            return False
    if shake > 0:
        mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
        steps(0.1, lambda f: m.opt.gravity.__setitem__(slice(None), f * G * down))
        for axis in range(3):
            a = np.eye(3)[axis] * shake * G
            steps(0.5, lambda f, a=a: m.opt.gravity.__setitem__(
                slice(None), G * down + a * math.sin(4 * math.pi * f)))
            if moved(xh, qh):
                return False
    return not moved(xh, qh)


def _options(condim: int) -> str:
    # the arena: a gripper's pads on a finely meshed part make hundreds of contacts (330 on a
    # Jaco finger segment overflowed MuJoCo's default)
    return (f'<option timestep="{DT}" integrator="implicitfast" cone="elliptic" impratio="10" '
            'noslip_iterations="10" gravity="0 0 0"/><size memory="128M"/>')


def simulate_points(doc: dict, mesh_path: Path, shake: float = 1.0) -> list[bool]:
    mesh = doc["mesh"]
    com, length = np.asarray(mesh["center_mass"], float), float(mesh["length"])
    s = SIZE / length
    mu = float(doc["params"]["mu"])
    condim = 1 if mu == 0 else 3
    solref = [2 * DT, 1.0]
    convex, tris = _bodies(mesh_path)
    volume = float(mesh.get("volume") or 0.0)
    if volume <= 0:  # no closed body: weigh the hull, as the inertia does
        volume = trimesh.load(mesh_path, force="mesh", process=True).convex_hull.volume
    mass = DENSITY * volume * s**3
    inertia = _closed_inertia(mesh_path, com) * DENSITY * s**5
    out = []
    for g in doc["grasps"]:
        P, N = np.asarray(g["points"], float), np.asarray(g["normals"], float)
        C = np.asarray(g["fingers"]["tip_centers"], float)
        pieces = _pieces(convex, tris, C,
                         NEAR_RTOL * length + 2 * float(g["fingers"]["tip_radius"]),
                         SLAB_RTOL * length)
        assets, body = _part_xml(pieces, com, np.eye(3), np.zeros(3), s, mass, inertia, condim,
                                 [mu, 0, 0], solref)
        A = np.asarray(g["fingers"]["approach"], float)
        r = float(g["fingers"]["tip_radius"]) * s
        pre = (_preload(P, N, com) if mu == 0 else _friction_preload(P, N, com, mu)) * GRIP
        fingers, acts = [], []
        kv = 2 * math.sqrt(STIFF * TIP_MASS)
        for j, (c, a) in enumerate(zip(C, A, strict=True)):
            fingers.append(f'<body pos="{_fmt((c - com) * s + 0.5 * r * a)}" gravcomp="1">'
                           f'<joint name="j{j}" type="slide" axis="{_fmt(-a)}"/>'
                           f'<geom type="sphere" size="{r:.9g}" mass="{TIP_MASS}" contype="2" '
                           f'conaffinity="1" condim="{condim}" friction="{mu} 0 0" '
                           f'solref="{_fmt(solref)}"/></body>')
            acts.append(f'<position joint="j{j}" kp="{STIFF}" kv="{kv:.9g}" forcelimited="true" '
                        f'forcerange="{-GRIP} {GRIP}"/>')
        xml = (f"<mujoco>{_options(condim)}<asset>{assets}</asset><worldbody>{body}"
               + "".join(fingers) + f"</worldbody><actuator>{''.join(acts)}</actuator></mujoco>")
        touch = np.full(len(C), 0.5 * r)
        out.append(_run(xml, touch, touch + pre / STIFF, pre, SIZE, GRIP / STIFF,
                        np.array([0, 0, -1.0]), shake))
    return out


def simulate_jaws(doc: dict, mesh_path: Path, shake: float = 1.0) -> list[bool]:
    import trimesh.units

    m_per = float(trimesh.units.unit_conversion(doc["mesh"]["units"], "meters"))
    desc = json.loads((GRIPPERS / f"{doc['gripper']['source']}.json").read_text())
    pad_y, pad_z = desc["pad"]["center"]
    pad_w, pad_h = desc["pad"]["size"]
    table = np.array(desc.get("finger_z", [[0.0, 0.0], [desc["max_opening"], 0.0]]))
    grip = float(desc["grip_force"])
    loaded = trimesh.load(mesh_path, force="mesh", process=True)
    closed = _weighed(loaded)
    volume = sum(b.volume for b in closed) if closed else loaded.convex_hull.volume
    com = (sum(b.volume * b.center_mass for b in closed) / volume) if closed else loaded.centroid
    model = doc["model"]
    mass = model.get("mass") or DENSITY * volume * m_per**3
    mu, torsion = float(model["mu"]), float(model.get("torsion") or 0.0) * m_per
    convex, tris = _bodies(mesh_path)
    inertia = _closed_inertia(mesh_path, com) * mass / volume * m_per**2
    length = float(np.linalg.norm(loaded.extents))
    size = length * m_per
    solref = [2 * DT, 1.0]
    out = []
    for g in doc["grasps"]:
        T = np.asarray(g["pose"], float)
        R, t = T[:3, :3], T[:3, 3]
        w = float(g["width"]) * m_per
        z = pad_z + float(np.interp(w, table[:, 0], table[:, 1]))
        th = 0.25 * min(pad_w, pad_h)
        gap = max(0.05 * w, 0.1 * th)
        # points over both pads' faces, in the part's frame, to pick the triangles near them
        ys = np.linspace(-pad_w / 2, pad_w / 2, 5)
        zs = np.linspace(-pad_h / 2, pad_h / 2, 5)
        grid = np.array([[sx * (w / 2 + gap * k / 2), sx * pad_y + y, z + zz] for sx in (1, -1)
                         for k in range(3) for y in ys for zz in zs]) / m_per
        near = grid @ R.T + t
        pieces = _pieces(convex, tris, near, NEAR_RTOL * length + pad_w / m_per, SLAB_RTOL * length)
        assets, body = _part_xml(pieces, com, R, R.T @ (com - t) * m_per, m_per, mass, inertia, 4,
                                 [mu, torsion, 0], solref)
        pads = "".join(
            f'<body gravcomp="1"><joint name="s{j}" type="slide" axis="{-sg} 0 0"/>'
            f'<geom type="box" size="{th / 2} {pad_w / 2} {pad_h / 2}" '
            f'pos="{sg * (w / 2 + gap + th / 2)} {sg * pad_y} {z}" mass="{TIP_MASS}" contype="2" '
            f'conaffinity="1" condim="4" friction="{mu} {torsion} 0" '
            f'solref="{_fmt(solref)}"/></body>'
            for j, sg in enumerate((1, -1)))
        kv = 2 * math.sqrt(STIFF * TIP_MASS)
        xml = (f"<mujoco>{_options(4)}<asset>{assets}</asset><worldbody>{body}{pads}</worldbody>"
               f'<equality><joint joint1="s0" joint2="s1" polycoef="0 1 0 0 0" '
               f'solref="{_fmt(solref)}"/></equality>'
               '<tendon><fixed name="t"><joint joint="s0" coef="1"/><joint joint="s1" coef="1"/>'
               '</fixed></tendon>'
               f'<actuator><position tendon="t" kp="{STIFF}" kv="{kv:.9g}" forcelimited="true" '
               f'forcerange="{-grip} {grip}"/></actuator></mujoco>')
        out.append(_run(xml, np.array([2 * gap]), np.array([2 * gap + w]), None, size, 0.0,
                        np.array([0, 0, 1.0]), shake))
    return out


def simulate(grasp_file: Path, mesh_file: Path, shake: float = 1.0) -> list[bool]:
    """Whether each grasp of ``grasp_file`` (planned on ``mesh_file``) is held."""
    doc = json.loads(Path(grasp_file).read_text())
    if doc["format"] == "synth.gripper_grasps":
        return simulate_jaws(doc, Path(mesh_file), shake)
    return simulate_points(doc, Path(mesh_file), shake)
