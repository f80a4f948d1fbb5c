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
from typing import Any, cast

import numpy as np
import trimesh

from synth.plan.render import run_title, same_units, save_png, scene_extras

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
    shown: dict[str, Any] = {"grasp_rank": None}
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
            cast(trimesh.visual.ColorVisuals, m.visual).face_colors = [70, 110, 200, 200]
            scene.add_geometry(m, geom_name=f"gripper_{i}")
    Path(path).write_bytes(same_units(scene, part).export(file_type="glb"))
    return Path(path)


def render_gripper_png(part: Any, plan: Any, path: str | Path, panels: int = 3) -> Path:
    """Draw up to ``panels`` of the best posed grippers, one row each, from the two or three
    sides that show their contacts (:mod:`synth.plan.picture`); widths in millimetres, as
    the table gives them."""
    from synth.plan.picture import GraspPicture, Hand, draw_grasps

    mm = 1000.0 / plan.gripper.unit_scale  # part units -> millimetres
    rows = []
    for i, g in enumerate(plan.grasps[:panels], 1):
        shapes = posed_gripper(plan, i - 1)
        tris = np.concatenate([np.asarray(m.triangles) for m in shapes])
        hand = Hand(tris, np.tile(_HAND_RGB, (len(tris), 1)), np.asarray(g.points),
                    np.asarray(g.normals), _PAD_RGB, opacity=0.55)
        margin = "" if g.margin is None else f"margin {g.margin:.2f}, "  # with a mass only
        rows.append(GraspPicture(hand, f"#{i}  width {g.width * mm:.1f} mm, {margin}"
                                 f"N/weight {g.squeeze_per_weight:.3f}, mu_min "
                                 f"{g.mu_min:.2g}, d* {g.d_star:.3f}",
                                 _fingers(shapes, plan.gripper), _side_views(g),
                                 face_on=False))
    fig = draw_grasps(part, rows, run_title(plan.mesh, plan.run_id,
                                            f": {plan.gripper.title} grasps", "\n"),
                      plan.message)
    return save_png(fig, path, plan.mesh, plan.run_id, atomic=False)


#: Colours of the gripper and of its two contacts (the +x pad's first).
_HAND_RGB = np.array([0.36, 0.50, 0.82])
_PAD_RGB = np.array([[0.85, 0.33, 0.10], [0.93, 0.69, 0.13]])


def _fingers(shapes: list[trimesh.Trimesh], gripper: Any) -> np.ndarray:
    """The points a view of a gripper grasp must show besides the part: its fingers (the
    palm may run off the picture)."""
    return np.vstack([m.vertices for m in shapes[len(gripper.palm):]])


def _side_views(g: Any) -> np.ndarray:
    """How much each view direction shows the jaws from the side: across the approach
    (the palm then hides nothing), the pads' faces edge-on."""
    from synth.plan.picture import VIEW_DIRECTIONS

    x, y, z = g.pose[:3, 0], g.pose[:3, 1], g.pose[:3, 2]
    d = VIEW_DIRECTIONS
    return 1.0 - np.abs(d @ z) + 0.5 * np.abs(d @ y) - 0.25 * np.abs(d @ x)
