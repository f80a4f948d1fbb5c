"""Load a mesh file (or a trimesh object) into a cleaned, checked :class:`Part`.

Repairs, each recorded in ``Part.repairs``: weld duplicated vertices (texture and normal
seams included), drop degenerate and duplicate faces and unused vertices, make the winding
consistent and the normals point outward, fill small holes, and if a body is still open try
manifold3d's merge of nearly coincident open edges. A body that stays open (a single-sided
surface, a scan with holes) is kept as a surface, with a warning in ``Part.warnings``. Files
without a usable surface raise :class:`~synth.errors.MeshError` naming the file and the
reason.

Bodies: every connected piece of every mesh in the file is a body. Bodies that touch, nearly
touch, overlap or nest form one rigid part (a convex decomposition is one part, not its
largest piece); closed bodies that overlap are united (:mod:`synth.part.compound`). Objects
far apart (a file holding several parts) are planned one at a time: ``body=`` chooses one by
index or by the name of one of its bodies (default: the largest), or ``"all"`` keeps them
together; each dropped object is listed in ``Part.dropped``.

Tolerances follow the data: the length of the whole file and the precision of its
coordinates (:func:`synth.part.tolerances.coordinate_precision`).
"""

from __future__ import annotations

import gc
import hashlib
import io
import os
from pathlib import Path
from typing import Any, cast

import numpy as np
import trimesh

from synth.errors import InputError, MeshError
from synth.filetype import MESH, MESH_FORMATS, require
from synth.isolate import NativeCrash
from synth.limits import MAX_COORDINATE, MAX_FACES
from synth.memory import reusing_memory
from synth.part import tolerances as tol
from synth.part.bodies import body_labels, is_convex, mesh_moments
from synth.part.compound import group_bodies, unite_overlapping
from synth.part.meshcache import face_geometry, scaled_zero
from synth.part.model import Part, checked_sharp_angle
from synth.part.repair import (
    close,
    drop_duplicate_faces,
    face_keys,
    fix_degenerate,
    open_edges,
    orient,
    tilted_normals,
    weld,
)
from synth.part.unreadable import explain, obj_problem

#: Coordinates precise to more than this share of the part's size are reported as coarse.
COARSE_RTOL = 1e-3

__all__ = ["SUPPORTED_FORMATS", "UNITLESS_FORMATS", "MAX_COORDINATE", "MAX_FACES",
           "length_unit", "load_part"]

#: File extensions accepted by :func:`load_part` (read by trimesh).
SUPPORTED_FORMATS: tuple[str, ...] = MESH_FORMATS
#: Those whose files never say their length unit (GLB/GLTF are in metres, 3MF names its unit):
#: a command that needs the unit refuses such a file without ``--units`` before reading it.
UNITLESS_FORMATS: tuple[str, ...] = ("stl", "obj", "ply", "off")

#: How the warning of a mesh whose length unit is unknown begins (``Part.warnings``).
UNIT_UNKNOWN = "length unit unknown"
#: A trimesh mesh is a reference cycle (its visuals, caches and queries point back to it), so
#: dropping the file as read frees nothing until Python's cycle collector runs, which may be
#: long after the part's own arrays were built beside it. From this many triangles read on,
#: the loader runs the collector itself (about 40 ms): the 1.3M-face blob of
#: ``scripts/bench_scale.py`` then peaks at 884 MB instead of 1,107 MB, and its load and
#: plan fault in a quarter fewer fresh pages.
_COLLECT_FACES = 100_000

#: Abbreviations accepted for ``units`` (trimesh wants full names such as "millimeters").
UNIT_ALIASES: dict[str, str] = {
    "mm": "millimeters", "cm": "centimeters", "dm": "decimeters", "m": "meters",
    "in": "inches", "inch": "inches", "ft": "feet", "um": "microns", "µm": "microns",
    "millimetres": "millimeters", "centimetres": "centimeters", "decimetres": "decimeters",
    "metres": "meters",
}

def _fail(name: str, reason: str) -> MeshError:
    return MeshError(f"{name}: {reason}")


#: The UTF-8 byte-order mark some editors put before a text file's first line.
_BOM = b"\xef\xbb\xbf"


def _read(path: Path) -> tuple[list[tuple[str, trimesh.Trimesh]], str, str | None]:
    name = str(path)
    if not path.exists():
        raise _fail(name, "no such file")
    if not path.is_file():
        raise _fail(name, "not a file")
    require(path, MESH)  # a grasp file or a database is named as such
    ext = path.suffix.lower().lstrip(".")
    if ext not in SUPPORTED_FORMATS:
        raise _fail(name, f"unsupported format {ext!r}; expected one of "
                          f"{', '.join(SUPPORTED_FORMATS)}")
    data = path.read_bytes()
    if len(data) == 0:
        raise _fail(name, "file is empty")
    digest = hashlib.sha256(data).hexdigest()
    # a text file's UTF-8 byte-order mark (editors on Windows write one): trimesh took it for
    # part of the first line, and an OBJ lost its first vertex to it
    # (a binary STL's free 80-byte header may start with the same bytes: only a text STL's
    # "solid" or a PLY's "ply" after the mark is a text file's)
    bom = data.startswith(_BOM) and (ext in ("obj", "off", "gltf") or (
        ext == "stl" and data[3:8].lower() == b"solid") or (ext == "ply" and data[3:6] == b"ply"))
    if bom:
        data = data[len(_BOM):]
    if ext == "glb":
        from synth.plan.result import scene_run_id

        run = scene_run_id(data)
        if run is not None:
            raise _fail(name, f"a scene synth plan wrote (run {run}): the part together with "
                        "its fingers, not a part; plan the mesh it was made from")
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
        # OBJ: one body per object ("o"), never welded to another (collision meshes store
        # their convex pieces as objects that share corner positions)
        extra: dict[str, Any] = {"split_objects": True, "group_material": False} \
            if ext == "obj" else {}
        if bom:  # the bytes without it, their neighbours (an OBJ's materials) found by path
            extra["resolver"] = trimesh.resolvers.FilePathResolver(str(path))
        loaded = trimesh.load(io.BytesIO(data) if bom else str(path), file_type=ext,
                              process=False, force=None, **extra)
    except Exception as e:  # trimesh raises many kinds, in its own words: the file's fault
        # is said in the format's (the reader's exception stays the cause, for a traceback)
        raise _fail(name, explain(path, ext, data)) from e
    # bodies in the order the file lists them (trimesh's OBJ reader reverses its objects)
    listed = [line[2:].strip() for line in data.decode("utf-8", "replace").splitlines()
              if line.startswith("o ")] if ext == "obj" else []
    bodies = _bodies(loaded, name, ext, listed)
    if ext == "obj" and any(_malformed(m) for _, m in bodies):
        # trimesh reads a vertex of two numbers as a 2-D mesh and keeps faces past the last
        # vertex: the line at fault, in the file's own numbering
        problem = obj_problem(data)
        if problem is not None:
            raise _fail(name, problem)
    return bodies, digest, getattr(loaded, "units", None)


def _malformed(mesh: trimesh.Trimesh) -> bool:
    """Whether a mesh as read has vertices other than (v, 3) or a face index outside them."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    return v.ndim != 2 or v.shape[1] != 3 or (
        f.size > 0 and (int(f.min()) < 0 or int(f.max()) >= len(v)))


def _bodies(loaded: object, name: str, ext: str, listed: list[str] | None = None
            ) -> list[tuple[str, trimesh.Trimesh]]:
    if isinstance(loaded, trimesh.Trimesh):
        return [("mesh", loaded)]
    if isinstance(loaded, trimesh.Scene):
        out = []
        order = {g: i for i, g in enumerate(listed or loaded.geometry)}
        nodes = sorted(loaded.graph.nodes_geometry,
                       key=lambda n: (order.get(loaded.graph[n][1], len(order)), str(n)))
        for node in nodes:
            transform, geom_name = loaded.graph[node]
            geom = loaded.geometry[geom_name]
            if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
                g = geom.copy()
                g.apply_transform(transform)
                out.append((str(node), g))
        if out:
            return out
    found = {"PointCloud": "only points", "Path2D": "only 2-D lines",
             "Path3D": "only lines"}.get(type(loaded).__name__, "nothing readable as triangles")
    raise _fail(name, f"holds no triangle mesh: {found} when read as {ext.upper()}")


def _split(mesh: trimesh.Trimesh) -> list[trimesh.Trimesh]:
    """Connected pieces: faces joined by shared edges, as ``Part`` counts its bodies."""
    labels = body_labels(mesh)
    if labels.max() == 0:
        return [mesh]
    return [cast(trimesh.Trimesh,
                 mesh.submesh([np.flatnonzero(labels == i)], append=True, repair=False))
            for i in range(int(labels.max()) + 1)]


def _size(mesh: trimesh.Trimesh) -> float:
    return abs(float(mesh.volume)) if mesh.is_watertight else float(mesh.area)


def _keep_triangle_normals(mesh: trimesh.Trimesh, meshes: list[trimesh.Trimesh],
                           tilted: list[np.ndarray | None], keyed: dict[bytes, np.ndarray]
                           ) -> None:
    """Give the faces of the part's ``mesh`` that a repair tilted the normals of the file's
    triangles they lie in: those the union's sliver repair tilted (``tilted``, per body of
    ``meshes``, which ``mesh`` concatenates), and those welding or the sliver repair of a
    piece tilted (``keyed``, by their corners; turned with the face where orienting turned
    it). A contact's normal is then the file's own (the corpus check found d* 7e-5 to 3e-4
    off on faces tilted by 6e-5 to 1e-3 rad)."""
    given = np.concatenate([np.full((len(m.faces), 3), np.nan) if t is None else t
                            for m, t in zip(meshes, tilted, strict=True)])
    if keyed:  # looked up for the faces that have them only, not one face at a time
        keys = face_keys(mesh)
        found = np.flatnonzero(np.isin(keys, np.array(list(keyed), dtype=keys.dtype))
                               & np.isnan(given[:, 0]))
        if len(found):
            given[found] = [keyed[key] for key in keys[found].tolist()]
    rows = np.flatnonzero(~np.isnan(given[:, 0]))
    if not len(rows):
        return
    normals = np.array(face_geometry(mesh)[0], float)
    turned = np.einsum("ij,ij->i", normals[rows], given[rows]) < 0  # oriented since
    normals[rows] = np.where(turned[:, None], -given[rows], given[rows])
    mesh._cache["face_normals"] = normals


def _usable(raw: list[tuple[str, trimesh.Trimesh]], weld_tol: float, sliver: float,
            moved: float) -> int:
    """How many triangles of the raw meshes welding at ``weld_tol`` and the sliver repair at
    ``sliver`` leave (as :func:`_pieces` counts them)."""
    kept = 0
    for _, m in raw:
        if len(m.faces):
            m = fix_degenerate(weld(m, weld_tol)[0], sliver, moved)[0]
            kept += len(drop_duplicate_faces(m)[0].faces)
    return kept


def _coarse(allv: np.ndarray, precision: float, length: float) -> str:
    """Why coordinates of this precision cannot carry a part of this size, in words."""
    top = float(np.abs(allv).max())
    if tol.stored_as_float32(allv):
        step = float(np.spacing(np.float32(top)))
        how = f"float32 coordinates of magnitude {top:.3g} are {step:.3g} apart"
    else:
        step = 2.0 * precision
        how = f"its coordinates are only precise to {precision:.3g}"
    than = f"coarser than the part itself ({length:.3g} across as read)" if step >= length \
        else f"too coarse for a part {length:.3g} across"
    return (f"its coordinates cannot resolve the part: {how}, {than}; move the part near the "
            "origin, or store it in double precision (or with more decimals)")


def _pieces(raw: list[tuple[str, trimesh.Trimesh]], name: str, repairs: list[str], soup: bool,
            keyed: dict[bytes, np.ndarray], decimated: tuple[int, int] | None = None
            ) -> tuple[list[tuple[str, trimesh.Trimesh]], float, float]:
    """Welded connected pieces of every raw mesh, the coordinates' precision and length.

    ``soup``: the format stores every triangle's corners apart (STL), so welding them is not
    a repair worth reporting. ``keyed`` gets the faces that welding and the sliver repair
    tilted (:func:`synth.part.repair.face_keys`) with their triangles' normals.
    ``decimated``: the file's triangles and the count asked for, when the raw meshes are
    their decimation (a mesh left unusable by it is refused in those words).
    """
    for _, m in raw:
        shape = np.shape(m.vertices)
        if len(shape) != 2 or shape[1] != 3:
            raise _fail(name, f"its vertices have {shape[-1] if len(shape) == 2 else 'no'} "
                        "coordinates each, expected 3 (x, y, z)")
        faces = np.asarray(m.faces)
        wrong = (faces < 0) | (faces >= len(m.vertices)) if len(faces) else None
        if wrong is not None and wrong.any():
            row = int(np.flatnonzero(wrong.any(axis=1))[0])
            bad = int(faces[row][wrong[row]][0])
            count = f"{len(m.vertices)} vert{'ex' if len(m.vertices) == 1 else 'ices'}"
            raise _fail(name, f"face {row} refers to vertex {bad}, but the file has {count} "
                        "(numbered from 0; a corrupt file?)")
    verts = [np.asarray(m.vertices, float) for _, m in raw]
    allv = verts[0] if len(verts) == 1 else np.concatenate(verts) if verts else np.zeros((0, 3))
    n_faces = sum(len(m.faces) for _, m in raw)
    if n_faces == 0 or len(allv) == 0:
        raise _fail(name, "no triangles")
    if n_faces > MAX_FACES:
        raise _fail(name, f"{n_faces:,} triangles, more than the {MAX_FACES:,} synth loads (a "
                    f"1.3M-triangle mesh takes about 3.5 s and 0.9 GB to load); decimate it on "
                    f"loading (--decimate N, Python: load_part(path, decimate=N); the "
                    f"surface error is reported) or first, e.g. with Blender's Decimate")
    if not np.isfinite(allv).all():
        bad = int((~np.isfinite(allv).all(axis=1)).sum())
        raise _fail(name, f"{bad} vertices have NaN or infinite coordinates")
    lo, hi = tol.bounds(allv)
    biggest = float(np.abs(np.concatenate([lo, hi])).max())
    if biggest > MAX_COORDINATE:
        raise _fail(name, f"a vertex coordinate has magnitude {biggest:.3g}, above the "
                    f"{MAX_COORDINATE:g} synth can score meaningfully (wrong unit, or a corrupt "
                    "file?); scale the mesh or move it near the origin")
    length = float(np.linalg.norm(hi - lo))
    if length <= 0:
        raise _fail(name, "all vertices coincide")
    precision = tol.coordinate_precision(allv)
    weld_tol = max(tol.WELD_RTOL * length, 2.0 * precision)
    sliver = max(tol.DEGENERATE_RTOL * length, precision)
    moved = tol.surface_tolerance(length, precision)
    counts = {"welded": 0, "repaired": 0, "degenerate": 0, "duplicate": 0}
    pieces: list[tuple[str, trimesh.Trimesh]] = []
    n_f = 0
    for gname, m in raw:
        n_f += len(m.faces)
        if len(m.faces) == 0:
            continue
        read = m
        m, welded = weld(m, weld_tol)
        counts["welded"] += welded
        m, k, j, came = fix_degenerate(m, sliver, moved)
        counts["repaired"] += k
        if k or (welded and not soup):  # corners may have moved: tilted faces keep their
            # triangles' normals, found again by their corners after the later repairs; the
            # file's, from their corners (not those an STL stores, which trimesh keeps when
            # they are close: float32 and up to 4e-4 rad off)
            # (trimesh.triangles.normals, with the zero of the part's size)
            normals, valid = trimesh.util.unitize(
                trimesh.triangles.cross(np.asarray(read.triangles, float)), check_valid=True,
                threshold=scaled_zero(read.vertices, 2))
            before = np.zeros((len(valid), 3))  # a degenerate triangle has none
            before[valid] = normals
            given = tilted_normals(m, before[came], max(moved, weld_tol))
            rows = np.flatnonzero(~np.isnan(given[:, 0]))
            if len(rows):
                keyed.update(zip(face_keys(m, rows).tolist(), given[rows], strict=True))
        counts["degenerate"] += j
        m, k = drop_duplicate_faces(m)
        counts["duplicate"] += k
        if len(m.faces) == 0:
            continue
        comps = _split(m)
        pieces.extend((gname if len(comps) == 1 else f"{gname}#{i}", c)
                      for i, c in enumerate(comps))
    if soup:
        counts["welded"] = 0  # STL stores every corner of every triangle: welding is reading
    for key, text in (("welded", "welded {} duplicated vertices"),
                      ("repaired", "repaired {} sliver faces (edge flips, merged corners)"),
                      ("degenerate", "dropped {} degenerate faces"),
                      ("duplicate", "dropped {} duplicate faces")):
        if counts[key]:
            repairs.append(text.format(counts[key]))
    kept = sum(len(c.faces) for _, c in pieces)
    if kept < 4:
        if decimated is not None:
            raise _fail(name, f"decimating its {decimated[0]:,} triangles to {decimated[1]:,} "
                        f"left only {kept} usable triangle(s); a solid needs at least 4: ask "
                        "for more faces (--decimate N, Python: decimate=N)")
        # the coordinates' precision, not the part's size, set the tolerances (its surface
        # tolerance among them) that left these: said so when the tolerances of its size
        # alone would have kept a solid's worth of triangles
        if moved > tol.ON_SURFACE_RTOL * length and \
                _usable(raw, tol.WELD_RTOL * length, tol.DEGENERATE_RTOL * length,
                        tol.ON_SURFACE_RTOL * length) >= 4:
            raise _fail(name, _coarse(allv, precision, length))
        raise _fail(name, f"only {kept} usable triangle(s) of {n_f}; a solid needs at least 4")
    v = np.concatenate([c.vertices for _, c in pieces])
    centred = v - v.mean(axis=0)
    thickness = np.linalg.svd(centred, compute_uv=False)[-1] / np.sqrt(len(centred))
    if thickness < tol.FLAT_RTOL * length:
        after = "" if decimated is None else \
            f" after decimating its {decimated[0]:,} triangles to {decimated[1]:,}"
        raise _fail(name, f"all vertices lie in one plane{after} (a flat sheet, no volume)")
    return pieces, precision, length


def _repair_bodies(pieces: list[tuple[str, trimesh.Trimesh]], name: str, repairs: list[str],
                   warnings: list[str]) -> list[tuple[str, trimesh.Trimesh, bool]]:
    """Orient every piece and close the open ones where possible."""
    out = []
    flipped = 0
    closes: list[str] = []
    still_open: list[tuple[str, int]] = []
    crashed: list[tuple[str, str]] = []
    for pname, m in pieces:
        m, k = orient(m, one_piece=True)  # a connected piece of _split
        flipped += k
        if not m.is_watertight and len(m.faces) >= 4:
            try:  # after a crash, the file's other bodies get trimesh's filling only
                m, what = close(m, native=not crashed)
            except NativeCrash as e:
                what = None
                crashed.append((pname, e.how))
            if what:
                closes.append(what if len(pieces) == 1 else f"{what} ({pname})")
        closed = bool(m.is_watertight and m.is_winding_consistent
                      and mesh_moments(m)[0] > 0)
        if not closed:
            still_open.append((pname, open_edges(m)))
        out.append((pname, m, closed))
    if flipped:
        repairs.append(f"re-oriented {flipped} faces (consistent winding, outward normals)")
    repairs.extend(closes)
    if crashed:
        where, how = crashed[0]
        which = "" if len(pieces) == 1 else f" on body {where}, so the file's later bodies " \
            "were not given to it"
        warnings.append(f"{name}: manifold3d crashed ({how}) closing open edges{which}; the "
                        "crash was confined to a child process and the bodies it would have "
                        "closed are kept open")
    if len(pieces) == 1 and still_open:
        warnings.append(
            f"{name}: mesh is not watertight ({still_open[0][1]} open edges); volume, centre of "
            "mass and inside tests are unreliable, normals at the open boundary are guesses, "
            "and closure scores assume a solid that is not there")
    elif still_open:
        shown = ", ".join(f"{p} ({e} open edges)" for p, e in still_open[:5])
        more = f" and {len(still_open) - 5} more" if len(still_open) > 5 else ""
        warnings.append(
            f"{name}: {len(still_open)} of {len(pieces)} bodies are open surfaces, kept as "
            f"surfaces that fingers touch and collide with but without an inside: {shown}{more}")
    return out


def _choose(groups: list[list[int]], bodies: list[tuple[str, trimesh.Trimesh, bool]],
            body: int | str, name: str) -> tuple[list[int], list[str], str | None]:
    """The bodies of the object ``body`` names; lines for the dropped objects; a note."""
    def label(g: list[int]) -> str:
        names = [bodies[i][0] for i in g]
        return names[0] if len(names) == 1 else f"{names[0]} and {len(names) - 1} more bodies"

    def describe(k: int) -> str:
        g = groups[k]
        faces = sum(len(bodies[i][1].faces) for i in g)
        return f"object {k} '{label(g)}' ({len(g)} bodies, {faces} faces)" if len(g) > 1 \
            else f"object {k} '{label(g)}' ({faces} faces)"

    n = len(groups)
    if body == "all" or (n == 1 and body in ("largest", 0)):
        return [i for g in groups for i in g], [], (
            f"kept all {n} objects of the file as one part" if n > 1 else None)
    if n == 1:
        names = [bodies[i][0] for i in groups[0]]
        if body in names or body == "object0":
            return groups[0], [], None
        raise _fail(name, f"body={body!r} not found: the file holds one object (bodies "
                    f"{names[:8]}); use 'largest', 0 or 'all'")
    if body == "largest":
        closed_vol = [sum(_size(bodies[i][1]) for i in g if bodies[i][2]) for g in groups]
        area = [sum(float(bodies[i][1].area) for i in g) for g in groups]
        k = int(np.argmax(closed_vol)) if max(closed_vol) > 0 else int(np.argmax(area))
        how = "largest"
    elif isinstance(body, (int, np.integer)) and not isinstance(body, bool):
        if not 0 <= int(body) < n:
            raise _fail(name, f"body={body} out of range: the file holds {n} objects far "
                        f"apart: {[describe(k) for k in range(n)]}")
        k, how = int(body), "chosen"
    else:
        hits = [k for k, g in enumerate(groups)
                if body == f"object{k}" or any(bodies[i][0] == body for i in g)]
        if not hits:
            raise _fail(name, f"body={body!r} not found; the file holds {n} objects far apart: "
                        f"{[describe(k) for k in range(n)]}, or use 'largest' or 'all'")
        k, how = hits[0], "chosen"
    dropped = [f"dropped {describe(j)}: the file holds {n} objects far apart and synth plans "
               f"one, {describe(k)} ({how}); choose another with --body (body=) an index, "
               "a name or 'all'" for j in range(n) if j != k]
    return groups[k], dropped, None


def _decimated(raw: list[tuple[str, trimesh.Trimesh]], target: object, name: str,
               repairs: list[str]) -> list[tuple[str, trimesh.Trimesh]]:
    """The raw meshes as one mesh of ``target`` triangles when they have more (the error is
    reported in ``repairs``); unchanged otherwise."""
    from synth.part.decimate import decimate_mesh

    if not (isinstance(target, (int, np.integer)) and not isinstance(target, bool)
            and 4 <= target <= MAX_FACES):
        raise MeshError(f"decimate: expected a face count from 4 to {MAX_FACES:,}, got "
                        f"{target!r}")
    if sum(len(m.faces) for _, m in raw) <= target:
        return raw
    offsets = np.cumsum([0] + [len(m.vertices) for _, m in raw])
    v = np.concatenate([np.asarray(m.vertices, float) for _, m in raw])
    f = np.concatenate([np.asarray(m.faces, np.int64) + o
                        for (_, m), o in zip(raw, offsets[:-1], strict=True)])
    try:
        d = decimate_mesh(v, f, int(target))
    except InputError as e:
        raise MeshError(f"{name}: {e}") from e
    lo, hi = tol.bounds(v)
    repairs.append(d.describe(float(np.linalg.norm(hi - lo))))
    return [("decimated", d.mesh)]


def length_unit(unit: object) -> str | None:
    """The unit name trimesh reads for ``unit`` (an alias such as ``mm`` resolved, see
    ``UNIT_ALIASES``), or None when it is not a length unit trimesh knows."""
    name = UNIT_ALIASES.get(str(unit).strip().lower(), unit)
    if not isinstance(name, str):  # trimesh knows units by name only
        return None
    try:
        trimesh.units.to_inch(name)
    except Exception:  # noqa: BLE001 - trimesh raises several kinds
        return None
    return name


def _valid_unit(unit: object) -> str | None:
    if not isinstance(unit, str):
        return None
    try:
        trimesh.units.to_inch(unit)
    except Exception:
        return None
    return unit


@reusing_memory
def load_part(
    source: str | os.PathLike[str] | trimesh.Trimesh,
    units: str | None = None,
    *,
    body: int | str = "largest",
    sharp_angle: float = tol.SHARP_ANGLE,
    decimate: int | None = None,
) -> Part:
    """Load and clean a mesh into a :class:`Part`.

    Parameters
    ----------
    source : path or trimesh.Trimesh
        STL (ASCII or binary), OBJ, PLY, OFF, GLB/GLTF or 3MF file, or a mesh.
    units : str, optional
        Length unit (trimesh unit name, e.g. ``"millimeters"``, or an abbreviation such as
        ``"mm"``); default: the unit the file declares, else unknown (recorded in
        ``Part.warnings``).
    body : int, str
        Which object of a file holding several objects far apart: ``"largest"`` (default),
        ``"all"``, an index, or the name of one of its bodies. Bodies that touch, nearly
        touch or overlap are always one object (one rigid part).
    sharp_angle : float
        Dihedral threshold in radians for sharp edges, in (0, pi).
    decimate : int, optional
        Decimate a mesh of more triangles than this to this many (from 4 to ``MAX_FACES``)
        before anything else (:mod:`synth.part.decimate`; needs fast-simplification); the
        surface error is measured and reported in ``Part.repairs``. A mesh above
        ``MAX_FACES`` is refused without it.

    Returns
    -------
    Part

    Raises
    ------
    MeshError
        Missing or unreadable file (what is wrong with it said in the format's words, never
        the reader's), no usable surface (empty, fewer than 4 triangles, also after
        ``decimate``, flat, NaN or infinite coordinates or any of magnitude above
        ``MAX_COORDINATE``, coordinates too coarse for the part: float32 far from the
        origin), an unknown unit or body.

    Examples
    --------
    >>> part = load_part("meshes/cube.stl", units="decimeters")  # doctest: +SKIP
    """
    checked_sharp_angle(sharp_angle)  # before the file is read
    repairs: list[str] = []
    warnings: list[str] = []
    if isinstance(source, trimesh.Trimesh):
        name, digest, path = "<trimesh.Trimesh>", None, None
        raw = [("mesh", source.copy())]
        declared = source.units
    elif isinstance(source, (str, os.PathLike)):
        p = Path(source)
        name, path = str(p), str(p)
        raw, digest, declared = _read(p)
    else:
        raise MeshError(f"source: expected a path or trimesh.Trimesh, got {type(source).__name__}")
    unit = units if units is not None else _valid_unit(declared)
    if unit is not None:
        known = length_unit(unit)
        if known is None:
            raise MeshError(f"{name}: unknown length unit {unit!r}; use mm, cm, dm, m, um, in, "
                            "ft or a trimesh unit name such as 'millimeters'")
        unit = known
    else:
        warnings.append(f"{UNIT_UNKNOWN}: the file does not say it; give it with --units "
                        "(Python: units=), e.g. mm, cm, m or in")
    soup = path is not None and Path(path).suffix.lower() == ".stl"
    decimated = None
    if decimate is not None:
        n_file = sum(len(m.faces) for _, m in raw)
        raw = _decimated(raw, decimate, name, repairs)
        if raw[0][0] == "decimated":  # one welded mesh now, whatever the file was
            soup, decimated = False, (n_file, int(decimate))
    keyed: dict[bytes, np.ndarray] = {}
    pieces, precision, length = _pieces(raw, name, repairs, soup, keyed, decimated)
    if precision > COARSE_RTOL * length:
        warnings.append(f"coarse coordinates: they are precise only to {precision:.3g}, "
                        f"{100 * precision / length:.2g}% of the part's size ({length:.3g}), so "
                        "its edges and tolerances are that coarse (float32 coordinates far from "
                        "the origin?); move the part near the origin or store it in double "
                        "precision")
    n_read = sum(len(m.faces) for _, m in raw)
    del raw  # the file as read: a large mesh's biggest copy, not needed past welding
    if n_read >= _COLLECT_FACES:
        gc.collect()  # (see _COLLECT_FACES)
    bodies = _repair_bodies(pieces, name, repairs, warnings)
    groups, crashes = group_bodies([b[1] for b in bodies], [b[2] for b in bodies],
                                   tol.GROUP_GAP_RTOL)
    warnings.extend(f"{name}: {w}" for w in crashes)
    chosen, dropped, note = _choose(groups, bodies, body, name)
    if note:
        repairs.append(note)
    meshes, names, sources, tilted, notes = unite_overlapping([bodies[i][1] for i in chosen],
                                             [bodies[i][0] for i in chosen],
                                             [bodies[i][2] for i in chosen],
                                             max(tol.DEGENERATE_RTOL * length, precision),
                                             tol.surface_tolerance(length, precision), keyed)
    repairs.extend(notes)
    if len(meshes) == 1 and type(meshes[0]) is trimesh.Trimesh:
        # one body, as the repairs above built it (plain arrays, no visuals): kept, with the
        # adjacency, watertightness and convexity they computed, which the part reads again
        mesh = meshes[0]
    else:
        both = meshes[0] if len(meshes) == 1 else cast(trimesh.Trimesh,
                                                       trimesh.util.concatenate(meshes))
        mesh = trimesh.Trimesh(np.asarray(both.vertices, float),
                               np.asarray(both.faces, np.int64), process=False)
    _keep_triangle_normals(mesh, meshes, tilted, keyed)
    # the closed convex bodies of the file, by their index among those chosen: a body united
    # from such pieces is exactly their union, so a consumer that needs convex pieces (the
    # simulator) takes them instead of decomposing the union again. Judged with the part's
    # tolerance, as the part judges its bodies (a file's other objects far away make its
    # length, and so its tolerance, larger)
    part_tol = tol.surface_tolerance(float(np.linalg.norm(mesh.extents)), precision)
    convex_inputs = {k: np.asarray(bodies[i][1].vertices, float) for k, i in enumerate(chosen)
                     if bodies[i][2] and is_convex(bodies[i][1], part_tol)}
    # trimesh stores str(unit).lower(): "none" when the unit is unknown (GLB files carry it)
    mesh.units = str(unit)
    return Part(mesh, units=unit, sharp_angle=sharp_angle, repairs=repairs,
                warnings=warnings, source=path, sha256=digest, body_names=names,
                dropped=dropped, precision=precision, face_source=np.concatenate(sources),
                body=body, convex_inputs=convex_inputs, decimate=decimate)
