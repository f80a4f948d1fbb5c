"""Generate the sample meshes in ``meshes/`` with manifold3d (CSG) and trimesh.

Every mesh is in decimetres (trimesh unit string ``"decimeters"``): the numbers are of
order 1 and the objects are of graspable size (5 to 20 cm). See ``meshes/README.md``.

Run ``python scripts/make_meshes.py [outdir]``; the output is deterministic.
"""

from __future__ import annotations

import sys
from pathlib import Path

import manifold3d as mf
import numpy as np
import trimesh

__all__ = ["build_all", "main"]

UNITS = "decimeters"


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> mf.Manifold:
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    return mf.Manifold.cube(tuple(hi_a - lo_a), False).translate(tuple(lo_a))


def _to_trimesh(m: mf.Manifold) -> trimesh.Trimesh:
    mesh = m.to_mesh()
    verts = np.asarray(mesh.vert_properties, float)[:, :3]
    faces = np.asarray(mesh.tri_verts, np.int64)
    out = trimesh.Trimesh(verts, faces, process=True)
    if not out.is_watertight or out.volume <= 0:
        raise RuntimeError("generated mesh is not a closed, outward-oriented solid")
    return out


def cube() -> mf.Manifold:
    """Unit cube, edge 1, centred on the origin."""
    return mf.Manifold.cube((1.0, 1.0, 1.0), True)


def prism() -> mf.Manifold:
    """Triangular prism: equilateral triangle of side 1 extruded 1.5 along z, centred."""
    h = np.sqrt(3.0) / 2.0
    tri = mf.CrossSection([[(-0.5, -h / 3.0), (0.5, -h / 3.0), (0.0, 2.0 * h / 3.0)]])
    return mf.Manifold.extrude(tri, 1.5).translate((0.0, 0.0, -0.75))


def bracket() -> mf.Manifold:
    """Corner bracket: base plate, upright plate and a side wall (0.25 thick).

    Concave edges run where the plates meet; the point (0.25, 0.25, 0.25) is an inside
    corner where three concave faces meet.
    """
    base = _box((0, 0, 0), (2.0, 1.0, 0.25))
    upright = _box((0, 0, 0), (0.25, 1.0, 1.5))
    wall = _box((0, 0, 0), (1.0, 0.25, 1.0))
    return base + upright + wall


def tee() -> mf.Manifold:
    """T-shaped block: a 2 x 0.5 x 0.5 bar on a 0.5 x 0.5 x 1.5 stem."""
    stem = _box((-0.25, -0.25, 0.0), (0.25, 0.25, 1.5))
    bar = _box((-1.0, -0.25, 1.5), (1.0, 0.25, 2.0))
    return stem + bar


def nut() -> mf.Manifold:
    """Hexagonal nut: 1.0 across flats, 0.5 high, hole of diameter 0.5 (48 segments)."""
    r_corner = 0.5 / np.cos(np.pi / 6.0)
    ang = np.arange(6) * np.pi / 3.0
    hexagon = mf.CrossSection([np.c_[r_corner * np.cos(ang), r_corner * np.sin(ang)].tolist()])
    body = mf.Manifold.extrude(hexagon, 0.5)
    hole = mf.Manifold.cylinder(1.0, 0.25, 0.25, 48, True)
    return body - hole


def cylinder() -> mf.Manifold:
    """Cylinder of radius 0.5 and height 1.5 about z, 64 segments, centred."""
    return mf.Manifold.cylinder(1.5, 0.5, 0.5, 64, True)


def sphere() -> mf.Manifold:
    """Sphere of radius 0.5, 40 segments around."""
    return mf.Manifold.sphere(0.5, 40)


def torus() -> mf.Manifold:
    """Torus about z: major radius 0.6, minor radius 0.2, 48 x 24 segments."""
    circle = mf.CrossSection.circle(0.2, 24).translate((0.6, 0.0))
    return mf.Manifold.revolve(circle, 48)


_BUILDERS = {
    "cube": cube,
    "prism": prism,
    "bracket": bracket,
    "tee": tee,
    "nut": nut,
    "cylinder": cylinder,
    "sphere": sphere,
    "torus": torus,
}


def build_all() -> dict[str, trimesh.Trimesh]:
    """Return every sample mesh by name.

    Returns
    -------
    meshes : dict of str to trimesh.Trimesh
        Closed, outward-oriented meshes in decimetres.
    """
    out = {}
    for name, build in _BUILDERS.items():
        mesh = _to_trimesh(build())
        mesh.units = UNITS
        out[name] = mesh
    return out


def main(argv: list[str] | None = None) -> int:
    """Write ``<name>.stl`` (binary) for every sample mesh into ``outdir`` (default meshes/)."""
    args = sys.argv[1:] if argv is None else argv
    outdir = Path(args[0]) if args else Path(__file__).resolve().parent.parent / "meshes"
    outdir.mkdir(parents=True, exist_ok=True)
    for name, mesh in build_all().items():
        path = outdir / f"{name}.stl"
        mesh.export(path, file_type="stl")
        ext = mesh.extents
        print(f"{path.name:14s} faces={len(mesh.faces):5d} extents={np.round(ext, 4)} "
              f"volume={mesh.volume:.4f} size={path.stat().st_size} B")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
