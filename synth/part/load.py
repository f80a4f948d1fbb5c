"""Load a mesh file (or a trimesh object) into a cleaned, checked :class:`Part`.

Repairs, each recorded in ``Part.repairs``: weld duplicated vertices (texture and normal
seams included), drop degenerate and duplicate faces and unused vertices, make the winding
consistent and the normals point outward, fill small holes, and if the mesh is still open
try manifold3d's merge of nearly coincident open edges. A mesh that stays open is accepted
with a warning in ``Part.warnings``. Files without a usable surface raise
:class:`~synth.errors.MeshError` naming the file and the reason.

Bodies: a file (or scene) with several bodies keeps the one with the largest volume (area
for open bodies) by default; pass ``body=`` an index (in the order reported in the repair
note), a geometry name, or ``"all"`` to merge them.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import trimesh

from synth.errors import MeshError
from synth.part import tolerances as tol
from synth.part.model import Part

__all__ = ["SUPPORTED_FORMATS", "load_part"]

#: File extensions accepted by :func:`load_part` (read by trimesh).
SUPPORTED_FORMATS: tuple[str, ...] = ("stl", "obj", "ply", "off", "glb", "gltf", "3mf")



#: Abbreviations accepted for ``units`` (trimesh wants full names such as "millimeters").
UNIT_ALIASES: dict[str, str] = {
    "mm": "millimeters", "cm": "centimeters", "dm": "decimeters", "m": "meters",
    "in": "inches", "inch": "inches", "ft": "feet", "um": "microns", "µm": "microns",
    "millimetres": "millimeters", "centimetres": "centimeters", "decimetres": "decimeters",
    "metres": "meters",
}

def _fail(name: str, reason: str) -> MeshError:
    return MeshError(f"{name}: {reason}")


def _read(path: Path) -> tuple[list[tuple[str, trimesh.Trimesh]], str, str | None]:
    name = str(path)
    if not path.exists():
        raise _fail(name, "no such file")
    if not path.is_file():
        raise _fail(name, "not a file")
    ext = path.suffix.lower().lstrip(".")
    if ext not in SUPPORTED_FORMATS:
        raise _fail(name, f"unsupported format {ext!r}; expected one of {SUPPORTED_FORMATS}")
    data = path.read_bytes()
    if len(data) == 0:
        raise _fail(name, "file is empty")
    digest = hashlib.sha256(data).hexdigest()
    if ext == "stl" and not data[:5].lower().startswith(b"solid") and len(data) >= 84:
        count = int(np.frombuffer(data[80:84], "<u4")[0])
        if len(data) < 84 + 50 * count:
            raise _fail(name, f"not a complete binary STL: header announces {count} "
                        f"triangles ({84 + 50 * count} bytes), file has {len(data)} bytes "
                        "(truncated, or not an STL file)")
    if ext in ("obj", "off", "gltf"):
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as e:
            raise _fail(name, f"not a text {ext.upper()} file (bytes are not UTF-8)") from e
    try:
        loaded = trimesh.load(str(path), file_type=ext, process=False, force=None)
    except Exception as e:  # trimesh raises many kinds
        raise _fail(name, f"cannot be read as {ext.upper()} ({type(e).__name__}: {e})") from e
    return _bodies(loaded, name), digest, getattr(loaded, "units", None)


def _bodies(loaded: object, name: str) -> list[tuple[str, trimesh.Trimesh]]:
    if isinstance(loaded, trimesh.Trimesh):
        return [("mesh", loaded)]
    if isinstance(loaded, trimesh.Scene):
        out = []
        for node in loaded.graph.nodes_geometry:
            transform, geom_name = loaded.graph[node]
            geom = loaded.geometry[geom_name]
            if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
                g = geom.copy()
                g.apply_transform(transform)
                out.append((str(node), g))
        if out:
            return out
    raise _fail(name, f"holds no triangle mesh (found {type(loaded).__name__})")


def _choose(bodies: list[tuple[str, trimesh.Trimesh]], body: int | str, name: str,
            repairs: list[str]) -> trimesh.Trimesh:
    if len(bodies) == 1 and body in ("largest", 0, "all", bodies[0][0]):
        return bodies[0][1]
    names = [b[0] for b in bodies]
    if body == "all":
        repairs.append(f"merged {len(bodies)} bodies {names} into one part")
        return trimesh.util.concatenate([b[1] for b in bodies])
    if body == "largest":
        size = [abs(m.volume) if m.is_watertight else m.area for _, m in bodies]
        k = int(np.argmax(size))
        repairs.append(f"{len(bodies)} bodies {names}; kept body {k} {names[k]!r} "
                       "(largest); pass body= an index, a name or 'all' to choose")
        return bodies[k][1]
    if isinstance(body, (int, np.integer)) and not isinstance(body, bool):
        if not 0 <= body < len(bodies):
            raise _fail(name, f"body={body} out of range: {len(bodies)} bodies {names}")
        return bodies[int(body)][1]
    if body in names:
        return bodies[names.index(body)][1]
    raise _fail(name, f"body={body!r} not found; bodies are {names}, or 'largest', 'all'")


def _split_components(mesh: trimesh.Trimesh) -> list[tuple[str, trimesh.Trimesh]]:
    parts = mesh.split(only_watertight=False)
    if len(parts) <= 1:
        return [("mesh", mesh)]
    return [(f"component{i}", p) for i, p in enumerate(parts)]


def _clean(mesh: trimesh.Trimesh, name: str, repairs: list[str], warnings: list[str]
           ) -> trimesh.Trimesh:
    v = np.asarray(mesh.vertices, float)
    f = np.asarray(mesh.faces, np.int64)
    if len(f) == 0 or len(v) == 0:
        raise _fail(name, "no triangles")
    if not np.isfinite(v).all():
        bad = int((~np.isfinite(v).all(axis=1)).sum())
        raise _fail(name, f"{bad} vertices have NaN or infinite coordinates")
    mesh = trimesh.Trimesh(v, f, process=False, validate=False)
    length = float(np.linalg.norm(np.ptp(v, axis=0)))
    if length <= 0:
        raise _fail(name, "all vertices coincide")
    n_v = len(mesh.vertices)
    digits = max(0, int(np.ceil(-np.log10(tol.WELD_RTOL * length))))
    mesh.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=digits)
    if len(mesh.vertices) < n_v:
        repairs.append(f"welded {n_v - len(mesh.vertices)} duplicated vertices")
    n_f = len(mesh.faces)
    keep = mesh.nondegenerate_faces(height=tol.DEGENERATE_RTOL * length)
    if not keep.all():
        mesh.update_faces(keep)
        repairs.append(f"dropped {int((~keep).sum())} degenerate faces")
    uniq = mesh.unique_faces()
    if not uniq.all():
        mesh.update_faces(uniq)
        repairs.append(f"dropped {int((~uniq).sum())} duplicate faces")
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) < 4:
        raise _fail(name, f"only {len(mesh.faces)} usable triangle(s) of {n_f}; "
                    "a solid needs at least 4")
    centred = mesh.vertices - mesh.vertices.mean(axis=0)
    thickness = np.linalg.svd(centred, compute_uv=False)[-1] / np.sqrt(len(centred))
    if thickness < tol.FLAT_RTOL * length:
        raise _fail(name, "all vertices lie in one plane (a flat sheet, no volume)")
    mesh = _orient(mesh, repairs)
    if not mesh.is_watertight:
        mesh = _close(mesh, name, repairs, warnings)
    return mesh


def _orient(mesh: trimesh.Trimesh, repairs: list[str]) -> trimesh.Trimesh:
    before = np.sort(mesh.faces, axis=1), mesh.faces.copy()
    trimesh.repair.fix_winding(mesh)
    trimesh.repair.fix_inversion(mesh, multibody=True)
    flipped = int((~(mesh.faces == before[1]).all(axis=1)).sum())
    if flipped:
        repairs.append(f"re-oriented {flipped} faces (consistent winding, outward normals)")
    return mesh


def _close(mesh: trimesh.Trimesh, name: str, repairs: list[str], warnings: list[str]
           ) -> trimesh.Trimesh:
    n_f = len(mesh.faces)
    trimesh.repair.fill_holes(mesh)
    if mesh.is_watertight:
        repairs.append(f"filled holes with {len(mesh.faces) - n_f} faces")
        return _orient(mesh, repairs)
    try:
        import manifold3d as mf

        m = mf.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32),
                    tri_verts=np.asarray(mesh.faces, np.uint32))
        m.merge()
        solid = mf.Manifold(m)
        if solid.status() == mf.Error.NoError and not solid.is_empty():
            out = solid.to_mesh()
            closed = trimesh.Trimesh(np.asarray(out.vert_properties, float)[:, :3],
                                     np.asarray(out.tri_verts, np.int64), process=True)
            if closed.is_watertight and closed.volume > 0:
                repairs.append("closed the mesh with manifold3d (merged open edges)")
                return closed
    except Exception:  # manifold3d refuses non-manifold input; fall through to warning
        pass
    warnings.append(
        f"{name}: mesh is not watertight ({len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))} open edges); "
        "volume, centre of mass and inside tests are unreliable, normals at the open "
        "boundary are guesses, and closure scores assume a solid that is not there"
    )
    return mesh


def _valid_unit(unit: object) -> str | None:
    if not isinstance(unit, str):
        return None
    try:
        trimesh.units.to_inch(unit)
    except Exception:
        return None
    return unit


def load_part(
    source: str | os.PathLike[str] | trimesh.Trimesh,
    units: str | None = None,
    *,
    body: int | str = "largest",
    sharp_angle: float = tol.SHARP_ANGLE,
) -> Part:
    """Load and clean a mesh into a :class:`Part`.

    Parameters
    ----------
    source : path or trimesh.Trimesh
        STL (ASCII or binary), OBJ, PLY, OFF, GLB/GLTF or 3MF file, or a mesh.
    units : str, optional
        Length unit (trimesh unit name, e.g. ``"millimeters"``); default: the unit the
        file declares, else unknown (recorded in ``Part.warnings``).
    body : int, str
        Which body of a multi-body file: ``"largest"`` (default), ``"all"``, an index
        or a name.
    sharp_angle : float
        Dihedral threshold in radians for sharp edges.

    Returns
    -------
    Part

    Raises
    ------
    MeshError
        Missing or unreadable file, no usable surface (empty, fewer than 4 triangles,
        flat, NaN or infinite coordinates).

    Examples
    --------
    >>> part = load_part("meshes/cube.stl", units="decimeters")  # doctest: +SKIP
    """
    repairs: list[str] = []
    warnings: list[str] = []
    if isinstance(source, trimesh.Trimesh):
        name, digest, path = "<trimesh.Trimesh>", None, None
        bodies = [("mesh", source.copy())]
        declared = source.units
    elif isinstance(source, (str, os.PathLike)):
        p = Path(source)
        name, path = str(p), str(p)
        bodies, digest, declared = _read(p)
    else:
        raise MeshError(f"source: expected a path or trimesh.Trimesh, got {type(source).__name__}")
    if len(bodies) == 1:
        mesh = _clean(bodies[0][1], name, repairs, warnings)
        components = _split_components(mesh)
        if len(components) > 1:
            mesh = _choose(components, body, name, repairs)
            mesh = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
            mesh.remove_unreferenced_vertices()
        elif body not in ("largest", "all", 0, "mesh"):
            raise _fail(name, f"body={body!r} not found: the file holds one body")
    else:
        mesh = _clean(_choose(bodies, body, name, repairs), name, repairs, warnings)
    unit = units if units is not None else _valid_unit(declared)
    if unit is not None:
        unit = UNIT_ALIASES.get(str(unit).strip().lower(), unit)
        try:
            trimesh.units.to_inch(unit)
        except Exception as e:
            raise MeshError(f"{name}: unknown length unit {unit!r} "
                            "(use a trimesh unit name such as 'millimeters')") from e
    else:
        warnings.append("length unit unknown (pass units=...)")
    mesh.units = unit
    return Part(mesh, units=unit, sharp_angle=sharp_angle, repairs=repairs,
                warnings=warnings, source=path, sha256=digest)
