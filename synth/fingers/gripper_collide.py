"""Can a gripper pose be reached and closed without hitting the part or the table? (FCL)

For a pose and its grasp width, the checker tests, against every body of the part (one FCL
model, shared with the finger checker, :func:`synth.fingers.checker_for`) and a support plane:

1. the approach: every palm and finger shape at the open width swept along the approach axis
   from the pre-grasp distance to the pose (the convex hull of the shape at both ends, which
   contains the sweep, so the test is conservative), which also covers the hand at the pose
   with its jaws open;
2. the fingers at the grasp width, opened by ``clearance`` on each side (the pads touch the
   part there, so touching is not a collision);
3. a shape that meets no triangle of the part is wholly inside or wholly outside each closed
   body: one vertex of it inside a closed body (a finger in a mug's cavity that the mesh fills)
   is a hit too (FCL's mesh test sees surfaces only).

The table test is exact on the shapes' vertices: every vertex of the swept hulls and of the
closed fingers must lie on or above the plane.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull

from synth.fingers.collide import checker_for
from synth.fingers.gripper import Gripper

__all__ = ["GripperChecker", "CLEAR", "APPROACH_HITS", "FINGERS_HIT", "TABLE_HIT",
           "GRIPPER_STATUS"]

CLEAR, APPROACH_HITS, FINGERS_HIT, TABLE_HIT = 0, 1, 2, 3
#: Words for the codes of :meth:`GripperChecker.check`.
GRIPPER_STATUS: dict[int, str] = {CLEAR: "clear", APPROACH_HITS: "hand hits the part on the "
                                  "approach", FINGERS_HIT: "closed fingers hit the part",
                                  TABLE_HIT: "hand crosses the table"}


def _hull(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    h = ConvexHull(points)
    V = points[h.vertices]
    remap = np.full(len(points), -1)
    remap[h.vertices] = np.arange(len(h.vertices))
    return V, remap[h.simplices]


class GripperChecker:
    """Collision checks of gripper poses on one part (see the module).

    Parameters
    ----------
    part : Part or trimesh.Trimesh
    gripper : Gripper
        In the part's unit.
    pregrasp : float
        Length of the approach, in the part's unit.
    clearance : float
        How far each finger is backed off its pad's contact for the grasp-width test.
    table : float, optional
        Height of a support plane z = table in the part's frame.
    """

    def __init__(self, part: Any, gripper: Gripper, pregrasp: float, clearance: float,
                 table: float | None = None) -> None:
        self._checker = checker_for(part)
        self.gripper = gripper
        self.clearance = float(clearance)
        self.table = table
        back = np.array([0.0, 0.0, float(pregrasp)])
        self._swept = []
        for V, _ in gripper.meshes_at(gripper.max_opening):
            Vh, Fh = _hull(np.vstack([V, V - back]))
            self._swept.append((Vh, self._checker.mesh_object(Vh, Fh)))
        self._fingers = [(s.vertices, self._checker.mesh_object(s.vertices, s.faces))
                         for s in gripper.finger]
        self._solids = _closed_bodies(part)

    def check(self, poses: NDArray[np.float64], widths: NDArray[np.float64]
              ) -> NDArray[np.int64]:
        """Status code per pose: ``CLEAR`` or why it fails (the first failing test).

        Parameters
        ----------
        poses : (B, 4, 4) float
            Gripper frame to part frame.
        widths : (B,) float
            Grasp widths (pad distance).

        Returns
        -------
        (B,) int
        """
        out = np.full(len(poses), CLEAR, np.int64)
        probes: list[NDArray[np.float64]] = []
        probed: list[int] = []
        for b, (T, w) in enumerate(zip(poses, widths)):
            R, t = T[:3, :3], T[:3, 3]
            closed = [(Tf, V, obj) for Tf in self.gripper.finger_transforms(
                float(w) + 2.0 * self.clearance) for V, obj in self._fingers]
            if self.table is not None:
                low = min(float((V @ R.T + t)[:, 2].min()) for V, _ in self._swept)
                low = min([low] + [float(((V @ Tf[:3, :3].T + Tf[:3, 3]) @ R.T + t)[:, 2].min())
                                   for Tf, V, _ in closed])
                if low < self.table:
                    out[b] = TABLE_HIT
                    continue
            if any(self._checker.mesh_hits(obj, R, t) for _, obj in self._swept):
                out[b] = APPROACH_HITS
                continue
            if any(self._checker.mesh_hits(obj, R @ Tf[:3, :3], R @ Tf[:3, 3] + t)
                   for Tf, _, obj in closed):
                out[b] = FINGERS_HIT
                continue
            if self._solids:  # one vertex of each shape, tested below for all poses at once
                probes.append(np.vstack([np.array([V[0] for V, _ in self._swept]),
                                         [V[0] @ Tf[:3, :3].T + Tf[:3, 3] for Tf, V, _ in closed]])
                              @ R.T + t)
                probed.append(b)
        if probed:  # a shape inside a closed body, touching none of its triangles
            n_swept = len(self._swept)
            inside = _inside(self._solids, np.concatenate(probes)).reshape(len(probed), -1)
            rows = np.array(probed)
            out[rows[inside[:, n_swept:].any(axis=1)]] = FINGERS_HIT
            out[rows[inside[:, :n_swept].any(axis=1)]] = APPROACH_HITS
        return out


def _closed_bodies(part: Any) -> list[Any]:
    """The part's closed bodies as watertight trimesh meshes (a plain mesh: itself, when it is
    watertight)."""
    import trimesh

    bodies = getattr(part, "bodies", None)
    if bodies is None:
        return [part] if getattr(part, "is_watertight", False) else []
    mesh = part.mesh
    out = []
    for b in bodies:
        if b.closed:
            sub = mesh.submesh([np.asarray(b.faces)], append=True, repair=False)
            out.append(sub if isinstance(sub, trimesh.Trimesh) else mesh)
    return out


def _inside(solids: list[Any], points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which points lie inside one of the closed bodies ``solids``."""
    out = np.zeros(len(points), bool)
    for m in solids:
        lo, hi = m.bounds
        near = ~out & np.all((points >= lo) & (points <= hi), axis=1)
        if near.any():
            out[near] = m.contains(points[near])
    return out
