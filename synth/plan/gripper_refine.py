"""Refining the best gripper grasps: small moves of the pose that need less squeeze.

Each of the best grasps is moved a little: rotated about its closing axis through the tool
centre point by +-``REFINE_ANGLE`` degrees, and its tool centre point shifted along the pad's
width (y) and height (z) by a third of the pad's size. Each move closes the jaws again, is
checked for collisions, and is scored (closure and the squeeze against gravity, the coarse
icosphere's bound picking each grasp's best move and the fine bound confirming it); the grasp
takes that move if it needs less squeeze, and a second round tries moves half as large around
it. A move is a new pose: its contacts are where its own pads land.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.fingers.gripper import Gripper
from synth.fingers.gripper_collide import CLEAR, GripperChecker
from synth.fingers.jaws import LANDED, close_jaws
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import gravity_hold_batch

__all__ = ["REFINE_ANGLE", "REFINE_ROUNDS", "Scored", "refine"]

#: Rotation step about the closing axis, degrees (halved in each later round).
REFINE_ANGLE: float = 15.0
#: Rounds of moves.
REFINE_ROUNDS: int = 2


@dataclass(frozen=True)
class Scored:
    """Scored gripper grasps (S of them), as arrays.

    Attributes
    ----------
    poses : (S, 4, 4) float
    width : (S,) float
    points, normals : (S, 2, 3) float
    patch : (S, 2) float
    d_star : (S,) float
    spw : (S,) float
        Least squeeze per weight (certified bound over the directions).
    sampled : (S,) float
        Its worst sampled direction's value.
    worst : (S, 3) float
        That direction.
    """

    poses: NDArray[np.float64]
    width: NDArray[np.float64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    patch: NDArray[np.float64]
    d_star: NDArray[np.float64]
    spw: NDArray[np.float64]
    sampled: NDArray[np.float64]
    worst: NDArray[np.float64]

    def take(self, rows: NDArray[np.int64]) -> Scored:
        """The grasps ``rows``."""
        return Scored(*(np.asarray(getattr(self, f))[rows] for f in self.__dataclass_fields__))


def _moves(poses: NDArray[np.float64], gripper: Gripper, scale: float
           ) -> NDArray[np.float64]:
    """The 8 moved poses of each pose, (S, 8, 4, 4)."""
    a = np.radians(REFINE_ANGLE) * scale
    dy, dz = gripper.pad_size * scale / 3.0
    steps = [(a, 0, 0), (-a, 0, 0), (a / 2, 0, 0), (-a / 2, 0, 0),
             (0, dy, 0), (0, -dy, 0), (0, 0, dz), (0, 0, -dz)]
    R, t = poses[:, :3, :3], poses[:, :3, 3]
    tcp = np.einsum("sij,j->si", R, gripper.tcp) + t
    out = np.repeat(poses[:, None], len(steps), axis=1)
    for k, (ang, sy, sz) in enumerate(steps):
        c, s = np.cos(ang), np.sin(ang)
        Rx = np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
        Rk = R @ Rx
        centre = tcp + R[:, :, 1] * sy + R[:, :, 2] * sz
        out[:, k, :3, :3] = Rk
        out[:, k, :3, 3] = centre - np.einsum("sij,j->si", Rk, gripper.tcp)
    return out


def refine(best: Scored, part: Any, gripper: Gripper, checker: GripperChecker, mu: float,
           gamma: float, gravity: Any, edges: int) -> Scored:
    """Move each grasp of ``best`` to the neighbouring pose that needs the least squeeze.

    Parameters
    ----------
    best : Scored
    part : Part
    gripper : Gripper
        In the part's unit.
    checker : GripperChecker
    mu, gamma : float
        Friction and torsion coefficients.
    gravity : (3,) or None
        As for :func:`synth.scores.gravity.gravity_hold_batch`.
    edges : int

    Returns
    -------
    Scored
        Same length and order; a grasp no move improves is unchanged.
    """
    mesh = part.mesh
    cur = best
    for r in range(REFINE_ROUNDS):
        if not len(cur.spw):
            break
        moved = _moves(cur.poses, gripper, 0.5**r).reshape(-1, 4, 4)
        owner = np.repeat(np.arange(len(cur.spw)), len(moved) // len(cur.spw))
        jaws = close_jaws(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                          np.asarray(mesh.face_normals), moved, gripper, part.surface_tolerance)
        ok = np.flatnonzero(jaws.status == LANDED)
        ok = ok[checker.check(jaws.poses[ok], jaws.width[ok]) == CLEAR]
        if not len(ok):
            break
        P, N = jaws.points[ok], jaws.normals[ok]
        fc = frictional_form_closure_batch(P, N, mu, center=part.center_mass, edges=edges,
                                           compiled=False, torsion=gamma)
        ok, P, N, d = ok[fc.closure], P[fc.closure], N[fc.closure], fc.d_star[fc.closure]
        if not len(ok):
            break
        # the coarse icosphere picks each grasp's best move; the fine bound must confirm it
        coarse = gravity_hold_batch(P, N, mu, gamma, part.center_mass, part.length, gravity,
                                    edges, compiled=False, level=1).squeeze_per_weight
        pick = []
        for s in range(len(cur.spw)):
            mine = np.flatnonzero(owner[ok] == s)
            if len(mine) and np.isfinite(coarse[mine]).any():
                pick.append(mine[np.argmin(coarse[mine])])
        if not pick:
            break
        rows = np.array(pick)
        hold = gravity_hold_batch(P[rows], N[rows], mu, gamma, part.center_mass, part.length,
                                  gravity, edges, compiled=False)
        fields = {f: np.array(getattr(cur, f)) for f in cur.__dataclass_fields__}
        for k, j in enumerate(pick):
            s, i = owner[ok[j]], ok[j]
            if hold.squeeze_per_weight[k] < fields["spw"][s]:
                for name, value in (("poses", jaws.poses[i]), ("width", jaws.width[i]),
                                    ("points", P[j]), ("normals", N[j]),
                                    ("patch", jaws.patch[i]), ("d_star", d[j]),
                                    ("spw", hold.squeeze_per_weight[k]),
                                    ("sampled", hold.sampled[k]),
                                    ("worst", hold.worst_direction[k])):
                    fields[name][s] = value
        cur = replace(cur, **fields)
    return cur
