"""Pictures of a plan: a PNG (matplotlib, headless) and a GLB scene (trimesh).

Contacts are drawn as dots with their inward normals as short arrows, fingertips as spheres
and finger bodies as capsules (lines in the PNG) along their approach directions; a grasp's
contact regions (when computed) as patches in its contacts' colours. Both name
the plan's run (``Plan.run_id``): the PNG in its title and in a ``synth.run_id`` text chunk,
the GLB in its scene's extras (``scene.metadata["synth"]["run_id"]`` once loaded by trimesh).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from synth.files import write_atomic
from synth.plan.result import Plan

__all__ = ["render_png", "export_glb", "run_title", "save_png", "scene_extras"]

_COLOURS = np.array([[0.85, 0.33, 0.10], [0.00, 0.45, 0.74], [0.47, 0.67, 0.19],
                     [0.49, 0.18, 0.56], [0.93, 0.69, 0.13], [0.30, 0.75, 0.93]])


def render_png(part, plan: Plan, path: str | Path, panels: int = 4, atomic: bool = True
               ) -> Path:
    """Draw the part and up to ``panels`` of the best grasps, one panel each.

    Parameters
    ----------
    part : synth.Part
    plan : Plan
    path : str or Path
    panels : int
    atomic : bool
        Write whole or not at all (:mod:`synth.files`); False for a caller that already
        writes into a temporary file of its own, as ``synth plan`` does for its three files.

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    grasps = plan.grasps[:panels]
    n = max(1, len(grasps))
    cols = min(n, 2)
    rows = int(np.ceil(n / cols))
    fig = plt.figure(figsize=(5.5 * cols, 5.0 * rows), dpi=110)
    mesh = part.mesh
    light = np.array([0.4, 0.3, 0.85]) / np.linalg.norm([0.4, 0.3, 0.85])
    shade = 0.45 + 0.5 * np.clip(mesh.face_normals @ light, 0, 1)
    face_rgb = np.clip(shade[:, None] * np.array([[0.75, 0.78, 0.82]]), 0, 1)
    L = part.length
    for p in range(n):
        ax = fig.add_subplot(rows, cols, p + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(mesh.triangles, facecolors=face_rgb,
                                             edgecolors="none", alpha=0.55))
        if grasps:
            g = grasps[p]
            f = g.fingers
            tips = np.asarray(f["tip_centers"])
            app = np.asarray(f["approach"])
            for i, (pt, nm) in enumerate(zip(g.points, g.normals)):
                col = _COLOURS[i % len(_COLOURS)]
                ax.scatter(*pt, color=col, s=22, depthshade=False)
                ax.quiver(*pt, *(nm * 0.12 * L), color=col, linewidth=1.5,
                          arrow_length_ratio=0.3)
            if g.contact_regions is not None:
                for i, poly in enumerate(g.contact_regions.polygons):
                    col = _COLOURS[i % len(_COLOURS)]
                    if len(poly) >= 3:
                        ax.add_collection3d(Poly3DCollection([poly], facecolors=[col],
                                                             edgecolors=[col], linewidths=2,
                                                             alpha=0.85))
                    elif len(poly) == 2:
                        ax.plot(*np.asarray(poly).T, color=col, linewidth=4)
            for i, (c, a) in enumerate(zip(tips, app)):
                col = _COLOURS[i % len(_COLOURS)]
                end = c + a * f["body_length"]
                ax.plot(*np.stack([c, end]).T, color=col, linewidth=3, alpha=0.8)
                ax.scatter(*c, color=col, s=60, alpha=0.5, depthshade=False)
            tol = "" if g.contact_regions is None else (
                f", tolerance {g.contact_regions.tolerance:.3g}"
                + ("" if g.contact_regions.certified else " (sampled)"))
            ax.set_title(f"#{p + 1}  d* = {g.d_star:.4f}  {g.closure} closure\n"
                         f"conditioning {g.conditioning:.3f}, epsilon {g.epsilon:.4f}{tol}",
                         fontsize=9)
        else:
            ax.set_title(_wrap(plan.message), fontsize=8)
        lo, hi = mesh.bounds
        mid, half = (lo + hi) / 2, (hi - lo).max() / 2 * 1.35
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
        ax.tick_params(labelsize=6)
    surface = plan.params.get("surface")
    fig.suptitle(run_title(plan.mesh, plan.run_id)
                 + (f"   normals: {surface}" if surface else ""), fontsize=11)
    fig.tight_layout()
    return save_png(fig, path, plan.mesh, plan.run_id, atomic)


def run_title(mesh: dict, run_id: str, what: str = "") -> str:
    """The title of a plan's picture: the mesh file's name and the run id (``what``: words
    after the name, such as the gripper's grasps)."""
    name = Path(mesh.get("path") or "part").name
    return f"synth: {name}{what}   run {run_id}"


def save_png(fig, path: str | Path, mesh: dict, run_id: str,  # type: ignore[no-untyped-def]
             atomic: bool = True) -> Path:
    """Save a plan's matplotlib figure as a PNG whose text chunks name the run (``Title``,
    ``synth.run_id``) and the mesh (``synth.mesh_sha256``), then close the figure."""
    import matplotlib.pyplot as plt

    from synth import __version__

    out = Path(path)
    name = Path(mesh.get("path") or "part").name

    def save(target: Path) -> None:
        fig.savefig(target, format="png", metadata={
            "Title": f"synth: {name}, run {run_id}", "Software": f"synth {__version__}",
            "synth.run_id": run_id, "synth.mesh_sha256": str(mesh.get("sha256"))})

    try:
        if atomic:
            write_atomic(out, save)
        else:
            save(out)
    finally:
        plt.close(fig)
    return out


def scene_extras(mesh: dict, run_id: str, params: dict, **more: object) -> dict:
    """The ``synth`` extras of a plan's GLB scene: the run id, the mesh's SHA-256 and the
    parameters, and ``more`` (the grasp shown)."""
    return {"run_id": run_id, "mesh_sha256": mesh.get("sha256"), "params": params, **more}


def _patch(poly: np.ndarray, width: float) -> trimesh.Trimesh | None:
    """A region as a mesh: a convex polygon as a two-sided fan of triangles, a segment as a
    thin cylinder, a single point as nothing."""
    if len(poly) >= 3:
        n = len(poly)
        fan = np.array([[0, i, i + 1] for i in range(1, n - 1)])
        return trimesh.Trimesh(poly, np.vstack([fan, fan[:, ::-1]]), process=False)
    if len(poly) == 2 and np.linalg.norm(poly[1] - poly[0]) > 0:
        return trimesh.creation.cylinder(radius=width, segment=poly)
    return None


def _wrap(text: str, width: int = 70) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


def export_glb(part, plan: Plan, path: str | Path, grasp: int = 0, atomic: bool = True
               ) -> Path:
    """Write a GLB scene: the part, and grasp ``grasp``'s fingertips, bodies and normals.

    Parameters
    ----------
    part : synth.Part
    plan : Plan
    path : str or Path
    grasp : int
        Which grasp to show (0 = best); with no grasps, the part alone. The scene's extras
        hold the plan's ``run_id``, this grasp's rank, the mesh's SHA-256 and the parameters.
        Its contact regions, when computed, are patches ``region_i`` in the contacts' colours,
        lifted off the surface by 0.1% of the part's size.
    atomic : bool
        As for :func:`render_png`.

    Returns
    -------
    Path
    """
    scene = trimesh.Scene()
    scene.metadata["synth"] = scene_extras(plan.mesh, plan.run_id, plan.params,
                                           grasp_rank=grasp + 1 if plan.grasps else None)
    body = part.mesh.copy()
    body.visual.face_colors = [190, 195, 205, 255]
    scene.add_geometry(body, geom_name="part")
    if plan.grasps:
        g = plan.grasps[grasp]
        f = g.fingers
        r = float(f["tip_radius"])
        for i, (c, a) in enumerate(zip(np.asarray(f["tip_centers"]), np.asarray(f["approach"]))):
            col = (np.append(_COLOURS[i % len(_COLOURS)], 1.0) * 255).astype(np.uint8)
            tip = trimesh.creation.icosphere(subdivisions=2, radius=r)
            tip.apply_translation(c)
            tip.visual.face_colors = col
            scene.add_geometry(tip, geom_name=f"tip_{i}")
            length = float(f["body_length"])
            cap = trimesh.creation.capsule(height=length, radius=float(f["body_radius"]))
            # the capsule's axis is z; trimesh 4.5 and 5.x centre it on the origin, older
            # versions started it there: centred here, its middle goes halfway along the
            # approach, so the axis runs from the tip centre to the body's far end, as the
            # finger check's does
            cap.apply_translation([0.0, 0.0, -float(cap.bounds[:, 2].mean())])
            T = trimesh.geometry.align_vectors([0, 0, 1], a)
            T[:3, 3] = c + 0.5 * length * a
            cap.apply_transform(T)
            cap.visual.face_colors = col
            scene.add_geometry(cap, geom_name=f"finger_{i}")
        if g.contact_regions is not None:
            for i, (poly, n) in enumerate(zip(g.contact_regions.polygons, g.normals)):
                patch = _patch(np.asarray(poly) - 1e-3 * part.length * n, 3e-3 * part.length)
                if patch is not None:
                    patch.visual.face_colors = (np.append(_COLOURS[i % len(_COLOURS)], 0.8)
                                                * 255).astype(np.uint8)
                    scene.add_geometry(patch, geom_name=f"region_{i}")
        for i, (p, n) in enumerate(zip(g.points, g.normals)):
            arrow = trimesh.creation.cylinder(radius=0.004 * part.length,
                                              segment=[p, p + 0.1 * part.length * n])
            arrow.visual.face_colors = [20, 20, 20, 255]
            scene.add_geometry(arrow, geom_name=f"normal_{i}")
    data = scene.export(file_type="glb")
    if atomic:
        return write_atomic(path, data)
    Path(path).write_bytes(data)
    return Path(path)
