"""Pictures of gripper grasps: a PNG of the best poses and a GLB scene of the best one.

The GLB holds the part (``part``) and the posed gripper's collision shapes at the grasp width
(``gripper_0``, ``gripper_1``, ... in the order of :meth:`synth.fingers.Gripper.meshes_at`:
palm shapes, then the +x finger's, then the -x finger's), each already placed in the part's
frame, so a reader can check them against the JSON's ``pose`` and ``width``; the scene's
extras hold the run id, the mesh's SHA-256, the parameters and the grasp's pose and width. The
PNG names the run in its title and text chunks, as a point-finger plan's does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from synth.plan.render import run_title, save_png, scene_extras

__all__ = ["export_gripper_glb", "render_gripper_png", "posed_gripper"]


def posed_gripper(plan: Any, grasp: int = 0) -> list[trimesh.Trimesh]:
    """The gripper's shapes of grasp ``grasp``, posed in the part's frame at its width."""
    g = plan.grasps[grasp]
    R, t = g.pose[:3, :3], g.pose[:3, 3]
    return [trimesh.Trimesh(V @ R.T + t, F, process=False)
            for V, F in plan.gripper.meshes_at(g.width)]


def export_gripper_glb(part: Any, plan: Any, path: str | Path, grasp: int = 0) -> Path:
    """Write the part and grasp ``grasp``'s posed gripper as a GLB scene (with no grasp, the
    part alone); the scene's extras name the run, the mesh and the parameters as a point-
    finger plan's do (:func:`synth.plan.render.scene_extras`), and the grasp's pose and
    width."""
    from dataclasses import asdict

    scene = trimesh.Scene()
    shown = {"grasp_rank": None}
    if plan.grasps:
        g = plan.grasps[grasp]
        shown = {"grasp_rank": grasp + 1, "pose": g.pose.tolist(), "width": g.width}
    scene.metadata["synth"] = scene_extras(plan.mesh, plan.run_id, asdict(plan.params),
                                           gripper=plan.gripper.name, **shown)
    body = part.mesh.copy()
    body.visual.face_colors = [190, 195, 205, 255]
    scene.add_geometry(body, geom_name="part")
    if plan.grasps:
        for i, m in enumerate(posed_gripper(plan, grasp)):
            m.visual.face_colors = [70, 110, 200, 200]
            scene.add_geometry(m, geom_name=f"gripper_{i}")
    Path(path).write_bytes(scene.export(file_type="glb"))
    return Path(path)


def render_gripper_png(part: Any, plan: Any, path: str | Path, panels: int = 4) -> Path:
    """Draw the part with up to ``panels`` of the best posed grippers, one panel each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    n = max(1, min(panels, len(plan.grasps)))
    cols = min(n, 2)
    rows = int(np.ceil(n / cols))
    fig = plt.figure(figsize=(5.5 * cols, 5.0 * rows), dpi=110)
    mesh = part.mesh
    for p in range(n):
        ax = fig.add_subplot(rows, cols, p + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(mesh.triangles, facecolors=[0.75, 0.78, 0.82],
                                             edgecolors="none", alpha=0.6))
        pts = [np.asarray(mesh.vertices)]
        if plan.grasps:
            g = plan.grasps[p]
            for m in posed_gripper(plan, p):
                ax.add_collection3d(Poly3DCollection(m.triangles, facecolors=[0.3, 0.45, 0.8],
                                                     edgecolors="none", alpha=0.35))
                pts.append(np.asarray(m.vertices))
            ax.scatter(*g.points.T, color="crimson", s=30, depthshade=False)
            margin = "" if g.margin is None else f", margin {g.margin:.2f}"
            ax.set_title(f"#{p + 1}  width {g.width:.4g}{margin}\nsqueeze/weight "
                         f"{g.squeeze_per_weight:.3f}, mu_min {g.mu_min:.2g}", fontsize=9)
        else:
            ax.set_title(plan.message[:90], fontsize=8)
        allp = np.vstack(pts)
        lo, hi = allp.min(0), allp.max(0)
        mid, half = (lo + hi) / 2, (hi - lo).max() / 2 * 1.1
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.tick_params(labelsize=6)
    fig.suptitle(run_title(plan.mesh, plan.run_id, f": {plan.gripper.title} grasps"),
                 fontsize=11)
    fig.tight_layout()
    return save_png(fig, path, plan.mesh, plan.run_id, atomic=False)
