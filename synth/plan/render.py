"""Pictures of a plan: a PNG (matplotlib, headless) and a GLB scene (trimesh).

Contacts are drawn as dots with their inward normals as short arrows, fingertips as spheres
and finger bodies as capsules (lines in the PNG) along their approach directions; a grasp's
contact regions (when computed) as patches in its contacts' colours. Both name
the plan's run (``Plan.run_id``): the PNG in its title and in a ``synth.run_id`` text chunk,
the GLB in its scene's extras (``scene.metadata["synth"]["run_id"]`` once loaded by trimesh).
"""

from __future__ import annotations

import numbers
import os
from pathlib import Path
from typing import Any, cast

import numpy as np
import trimesh

from synth.errors import InputError
from synth.files import write_atomic
from synth.part.model import Part
from synth.plan.result import Plan

__all__ = ["render_png", "export_glb", "run_title", "save_png", "scene_extras", "same_units"]

_COLOURS = np.array([[0.85, 0.33, 0.10], [0.00, 0.45, 0.74], [0.47, 0.67, 0.19],
                     [0.49, 0.18, 0.56], [0.93, 0.69, 0.13], [0.30, 0.75, 0.93]])


def _check_args(part: Any, plan: Any, path: Any) -> None:
    """The part, plan and path every writer here takes, or an InputError naming the wrong one."""
    if not isinstance(part, Part):
        raise InputError(f"part: expected a synth.Part, got {type(part).__name__}")
    if not isinstance(plan, Plan):
        raise InputError(f"plan: expected a synth.Plan, got {type(plan).__name__}")
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"path: expected a file path, got {type(path).__name__}")


def render_png(part, plan: Plan, path: str | Path, panels: int = 3, atomic: bool = True
               ) -> Path:
    """Draw up to ``panels`` of the best grasps, one row each, from the two or three sides
    that show their contacts (:mod:`synth.plan.picture`).

    Parameters
    ----------
    part : synth.Part
    plan : Plan
    path : str or Path
    panels : int
        Grasps drawn, best first.
    atomic : bool
        Write whole or not at all (:mod:`synth.files`); False for a caller that already
        writes into a temporary file of its own, as ``synth plan`` does for its three files.

    Returns
    -------
    Path
    """
    from synth.plan.picture import GraspPicture, draw_grasps

    _check_args(part, plan, path)
    if isinstance(panels, bool) or not isinstance(panels, numbers.Integral) or panels < 1:
        raise InputError(f"panels: expected an integer of at least 1, got {panels!r}")
    rows = [GraspPicture(_finger_hand(g, 1e-3 * part.length), f"#{i}  " + _measures(g),
                         _finger_ends(g)) for i, g in enumerate(plan.grasps[:panels], 1)]
    surface = plan.params.get("surface")
    fig = draw_grasps(part, rows, run_title(plan.mesh, plan.run_id)
                      + (f"\n{_SURFACE_WORDS.get(surface, surface)}" if surface else ""),
                      plan.message)
    return save_png(fig, path, plan.mesh, plan.run_id, atomic)


#: How the picture's title says which normals scored the grasps (``--surface``).
_SURFACE_WORDS = {"both": "d* with the facets' normals and the smooth surface's, the lower",
                  "mesh": "d* with the facets' normals",
                  "smooth": "d* with the smooth surface's normals"}


def run_title(mesh: dict, run_id: str, what: str = "", sep: str = "   ") -> str:
    """The title of a plan's picture: the mesh file's name and the run id (``what``: words
    after the name, such as the gripper's grasps; ``sep`` between them and the run id, a
    newline to give the run id a line of its own)."""
    name = Path(mesh.get("path") or "part").name
    return f"synth: {name}{what}{sep}run\u00a0{run_id}"  # "run" and its id stay on one line


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


def same_units(scene: trimesh.Scene, part) -> trimesh.Scene:  # type: ignore[no-untyped-def]
    """Label every geometry of ``scene`` with the part's units, as its coordinates are.

    glTF readers take an unlabelled geometry for metres (trimesh does), so a scene whose part
    alone carried the file's units (``--units mm``) read as mixed units; unknown units are
    labelled ``none`` throughout, as the part is. The scene's ``synth`` extras name them too.
    """
    units = part.mesh.units or "none"
    for geometry in scene.geometry.values():
        geometry.units = units
    scene.metadata.setdefault("synth", {})["units"] = part.units
    return scene


def _measures(g) -> str:  # type: ignore[no-untyped-def]
    """The measures of a point-finger grasp, as the table prints them."""
    r = g.contact_regions
    tol = "" if r is None else (f", tolerance {r.tolerance:.3g}"
                                + ("" if r.certified else " (sampled)"))
    newtons = "" if g.least_squeeze is None else f", squeeze {g.least_squeeze:.2f} N"
    margin = "" if g.margin is None else f", margin {g.margin:.2f}"
    return (f"d* {g.d_star:.5f} ({g.closure} closure), conditioning {g.conditioning:.4f}, "
            f"epsilon {g.epsilon:.5f}, N/weight {g.squeeze_per_weight:.3f}{newtons}{margin}"
            f"{tol}")


def _finger_ends(g) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The points a view of a point-finger grasp must show: the fingers' ends, a tip radius
    beyond them."""
    f = g.fingers
    tips, app = np.asarray(f["tip_centers"]), np.asarray(f["approach"])
    return tips + app * (float(f["body_length"]) + float(f["tip_radius"]))


def _finger_hand(g, lift: float):  # type: ignore[no-untyped-def]
    """A point-finger grasp's hand: each finger's tip sphere and body, its contact regions
    (when computed) as patches ``lift`` off the surface, in its contacts' colours."""
    from synth.plan.picture import Hand

    f = g.fingers
    tips, app = np.asarray(f["tip_centers"]), np.asarray(f["approach"])
    which = np.asarray(f.get("contact_finger", range(len(g.points))), int)
    tris, cols = [], []
    for i, (c, a) in enumerate(zip(tips, app, strict=True)):
        tip = trimesh.creation.icosphere(subdivisions=2, radius=float(f["tip_radius"]))
        tip.apply_translation(c)
        body = trimesh.creation.cylinder(radius=float(f["body_radius"]), sections=16,
                                         segment=[c, c + a * float(f["body_length"])])
        for m in (tip, body):
            tris.append(np.asarray(m.triangles))
            cols.append(np.tile(_COLOURS[i % len(_COLOURS)], (len(m.faces), 1)))
    if g.contact_regions is not None:
        for i, (poly, n) in enumerate(zip(g.contact_regions.polygons, g.normals, strict=True)):
            if len(poly) < 3:  # a segment or a point: its contact's dot shows it
                continue
            patch = _patch(np.asarray(poly) - lift * n, 0.0)
            if patch is not None:
                tris.append(np.asarray(patch.triangles))
                cols.append(np.tile(_COLOURS[which[i] % len(_COLOURS)], (len(patch.faces), 1)))
    return Hand(np.concatenate(tris), np.concatenate(cols), np.asarray(g.points),
                np.asarray(g.normals), _COLOURS[which % len(_COLOURS)])


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
    _check_args(part, plan, path)
    n = len(plan.grasps)
    if isinstance(grasp, bool) or not isinstance(grasp, numbers.Integral) or not (
            0 <= grasp < max(n, 1)):
        raise InputError(f"grasp: expected an index from 0 to {max(n - 1, 0)} (the plan has "
                         f"{n} grasps), got {grasp!r}")
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
        for i, (c, a) in enumerate(zip(np.asarray(f["tip_centers"]), np.asarray(f["approach"]),
                                       strict=True)):
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
            cast(trimesh.visual.ColorVisuals, cap.visual).face_colors = col
            scene.add_geometry(cap, geom_name=f"finger_{i}")
        if g.contact_regions is not None:
            for i, (poly, n) in enumerate(zip(g.contact_regions.polygons, g.normals, strict=True)):
                patch = _patch(np.asarray(poly) - 1e-3 * part.length * n, 3e-3 * part.length)
                if patch is not None:
                    cast(trimesh.visual.ColorVisuals, patch.visual).face_colors = (
                        np.append(_COLOURS[i % len(_COLOURS)], 0.8) * 255).astype(np.uint8)
                    scene.add_geometry(patch, geom_name=f"region_{i}")
        for i, (p, n) in enumerate(zip(g.points, g.normals, strict=True)):
            arrow = trimesh.creation.cylinder(radius=0.004 * part.length,
                                              segment=[p, p + 0.1 * part.length * n])
            cast(trimesh.visual.ColorVisuals, arrow.visual).face_colors = [20, 20, 20, 255]
            scene.add_geometry(arrow, geom_name=f"normal_{i}")
    data = same_units(scene, part).export(file_type="glb")
    if atomic:
        return write_atomic(path, data)
    Path(path).write_bytes(data)
    return Path(path)
