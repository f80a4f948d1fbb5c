"""Mesh repairs the loader applies to each body: welding, degenerate and duplicate faces,
orientation, closing holes.

Degenerate faces (a smallest height below the tolerance) carry no normal. Dropping them, as
most tools do, opens the mesh: a sliver from CAD or a boolean is usually a *cap* (a corner
lying on the opposite edge) or a *needle* (two corners almost together) inside a closed
surface. So a cap is removed by flipping its longest edge with the neighbouring face, and a
needle by merging its two close corners; both keep a closed mesh closed. Only what cannot be
repaired this way (a sliver on an open boundary) is dropped.
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order

from synth.isolate import call_isolated
from synth.part.bodies import body_labels, mesh_moments
from synth.part.features import edge_closure
from synth.part.meshcache import face_geometry, scaled_zero
from synth.part.order import stable_order

__all__ = ["weld", "fix_degenerate", "tilted_normals", "face_keys", "drop_duplicate_faces",
           "orient", "close", "open_edges",
           "MERGE_CLOSE"]

#: The function :func:`close` runs in the child process (see :mod:`synth.isolate`).
MERGE_CLOSE = "synth.native:merge_close"

_PASSES = 8
#: A degenerate face is a needle when its apex lies within this many tolerance heights of an
#: end of its longest edge (flipping it would only make another sliver).
_NEEDLE_FACTOR = 1e3


def weld(mesh: trimesh.Trimesh, tol: float) -> tuple[trimesh.Trimesh, int]:
    """Merge vertices closer than about ``tol`` (texture and normal seams included).

    The vertices trimesh's ``merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=d)``
    merges, in its order: of the vertices the faces use, those whose coordinates round to the
    same multiple of ``10**-d`` become one, the first of them in the file's order, and the
    merged vertices keep the order of their first occurrence. Found here with one sort of
    64-bit keys of the rounded rows (every row compared with its group's first, so a key
    collision is never trusted: trimesh then merges); trimesh sorts the rows themselves,
    which at 3.9M vertices took 2.0 s against 0.5 s here, with the same arrays.

    Returns the welded copy and the number of vertices removed.
    """
    v = np.asarray(mesh.vertices, float)
    f = np.asarray(mesh.faces, np.int64)
    digits = max(0, int(np.ceil(-np.log10(tol))))
    used = np.zeros(len(v), bool)
    used[f] = True
    rows = np.flatnonzero(used)
    # (with no faces trimesh merges every vertex: left to it)
    merged = _merge_rows(_rounded(v, rows, digits)) if len(f) else None
    if merged is None:
        out = trimesh.Trimesh(v, f, process=False, validate=False)
        out.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=digits)
    else:
        first, inverse = merged
        renumber = np.zeros(len(v), np.int64)
        renumber[rows] = inverse
        out = trimesh.Trimesh(v[rows[first]], renumber[f], process=False, validate=False)
    return out, len(v) - len(out.vertices)


def _rounded(v: np.ndarray, rows: np.ndarray, digits: int) -> np.ndarray:
    """``np.round(v[rows] * 10**digits).astype(np.int64)``, the same values, with one
    temporary instead of three (at 3.9M rows each is 94 MB of fresh pages)."""
    q = np.take(v, rows, axis=0)
    q *= 10**digits
    np.round(q, out=q)
    return q.astype(np.int64)


#: Odd 64-bit multipliers of the weld's row keys (any distinct odd constants: equal keys are
#: checked).
_KEY_MULT = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9], np.uint64)


def _merge_rows(q: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Equal rows of ``q`` (m, 3) int: the first row of each distinct value, in order of
    first occurrence (u,), and each row's value's position among them (m,); None when two
    different rows share a key (the caller then finds them another way)."""
    m = len(q)
    if m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    key = np.zeros(m, np.uint64)
    for c in range(3):  # a multiply-xor mix, wrapping around
        key ^= q[:, c].astype(np.uint64) * _KEY_MULT[c]
        key ^= key >> np.uint64(29)
    # the key's high bits above each row's position, in one plain sort (0.02 s at 3.9M rows,
    # against 0.11 s for numpy's argsort of the keys); different rows that share those bits
    # (at 655k distinct rows, one file in twenty) are told apart by sorting the whole keys
    bits = np.uint64(m.bit_length())
    packed = key >> bits << bits | np.arange(m, dtype=np.uint64)
    packed.sort()
    order = (packed & np.uint64((1 << m.bit_length()) - 1)).astype(np.int64)
    runs = _runs(q, order, packed >> bits)
    del packed
    if runs is None:
        order = np.argsort(key)  # numpy's quicksort
        runs = _runs(q, order, key[order])
        if runs is None:
            return None
    new, first_sorted = runs
    group = np.cumsum(new) - 1  # of each sorted row
    by_first = stable_order(first_sorted, m)[0]
    place = np.empty(len(by_first), np.int64)
    place[by_first] = np.arange(len(by_first))
    inverse = np.empty(m, np.int64)
    inverse[order] = place[group]
    return first_sorted[by_first], inverse


def _runs(q: np.ndarray, order: np.ndarray, sorted_key: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray] | None:
    """Where a new key begins (m,) bool among the rows of ``q`` (m, 3) in ``order`` (m,),
    sorted by their keys ``sorted_key`` (m,), and the smallest position of each key (u,);
    None when two different rows share a key."""
    new = np.empty(len(order), bool)
    new[0] = True
    np.not_equal(sorted_key[1:], sorted_key[:-1], out=new[1:])
    # every row of a group equals the one before it in the sorted order, so all equal its
    # first: one gather of the rows
    inside = ~new[1:]
    rows = np.take(q, order, axis=0)  # (3x as fast as q[order] for (m, 3) rows)
    for c in range(3):
        if ((rows[1:, c] != rows[:-1, c]) & inside).any():
            return None
    return new, np.minimum.reduceat(order, np.flatnonzero(new))


def _heights(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Smallest height of each face; 0 where trimesh could not give the face a normal.

    A coordinate at a time (half the time of (f, 3, 3) corner arrays at 1.3M faces). Twice
    the area is measured as trimesh.triangles.normals measures it (the cross product of
    b - a and c - b; the same norm), so that its test of a normal is the same."""
    x = [np.take(v[:, k], f) for k in range(3)]  # (f, 3): coordinate k of the corners
    # the sides a - b, b - c, c - a, each as its three coordinates
    s = [[x[k][:, c] - x[k][:, (c + 1) % 3] for k in range(3)] for c in range(3)]
    del x
    a, b = s[0], s[1]
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    area2 = np.sqrt(cx * cx + cy * cy + cz * cz)
    del cx, cy, cz
    # squared lengths summed in the order numpy's einsum sums a row of three (x, z, then y),
    # so that the heights equal the former (f, 3, 3) einsum's bit for bit
    sq = [(c[0] * c[0] + c[2] * c[2]) + c[1] * c[1] for c in s]
    longest = np.sqrt(np.maximum(np.maximum(sq[0], sq[1]), sq[2]))
    h = np.where(longest > 0, area2 / np.where(longest > 0, longest, 1.0), 0.0)
    return np.where(area2 > scaled_zero(v, 2), h, 0.0)


def fix_degenerate(mesh: trimesh.Trimesh, height: float, max_move: float | None = None
                   ) -> tuple[trimesh.Trimesh, int, int, np.ndarray]:
    """Remove faces whose smallest height is below ``height`` (or that trimesh cannot give a
    normal) without opening the mesh.

    A flip moves the surface by less than the cap's height. A merge moves the faces around
    the merged corner by up to the distance it travels, so it is made only while that
    distance, added to those of earlier merges into the corner, is at most ``max_move``
    (None: ``1000 height``); a needle that would go farther is flipped instead.

    Returns the repaired mesh, the number of slivers repaired (edge flips and merges), the
    number dropped (those on an open boundary or left after a few passes) and, for each face
    of the result, the input face it came from.
    """
    v = np.asarray(mesh.vertices, float)
    f = np.asarray(mesh.faces, np.int64).copy()
    ids = np.arange(len(f))
    reach = _NEEDLE_FACTOR * height if max_move is None else float(max_move)
    drift = np.zeros(len(v))  # how far the corners merged into each vertex have travelled
    fixed = 0
    clean = False  # the last pass found nothing to repair: its heights stand
    for _ in range(_PASSES):
        proper = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
        f, ids = f[proper], ids[proper]
        bad = np.flatnonzero(_heights(v, f) < height)
        if not len(bad):
            clean = True
            break
        nv = len(v)
        directed = (f * nv + np.roll(f, -1, axis=1)).ravel()  # edge (j, j+1) of each face
        order = np.argsort(directed, kind="stable")
        keys = directed[order]
        busy = np.zeros(len(f), bool)
        remap = np.arange(nv)
        actions = 0
        for i in bad.tolist():
            if busy[i]:
                continue
            a = f[i]
            p = v[a]
            lens = np.linalg.norm(p - np.roll(p, -1, axis=0), axis=1)
            j = int(np.argmax(lens))  # longest edge a[j] -> a[j+1], apex a[j+2]
            u, w, apex = a[j], a[(j + 1) % 3], a[(j + 2) % 3]
            seg = v[w] - v[u]
            t = float(np.dot(v[apex] - v[u], seg) / max(np.dot(seg, seg), 1e-300))
            end = u if t < 0.5 else w
            move = drift[apex] + float(np.linalg.norm(v[apex] - v[end]))
            if min(t, 1.0 - t) * lens[j] <= _NEEDLE_FACTOR * height and move <= reach:
                if remap[apex] == apex and remap[end] == end:  # needle: merge
                    remap[apex] = end
                    drift[end] = max(drift[end], move)
                    busy[i] = True
                    actions += 1
                continue
            k = np.searchsorted(keys, w * nv + u)  # neighbour across (w -> u): a cap, flip
            if k >= len(keys) or keys[k] != w * nv + u:
                continue
            g = int(order[k] // 3)
            if busy[g]:
                continue
            b = f[g]
            x = b[(int(order[k] % 3) + 2) % 3]
            f[i] = (u, x, apex)
            f[g] = (x, w, apex)
            ids[i] = ids[g]  # both now lie on the neighbour (the cap has no area)
            busy[i] = busy[g] = True
            actions += 1
        fixed += actions
        if (remap != np.arange(nv)).any():
            f = remap[f]
        if not actions:
            break
    if clean:
        keep = np.ones(len(f), bool)
    else:
        proper = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])
        f, ids = f[proper], ids[proper]
        keep = _heights(v, f) >= height
    out = trimesh.Trimesh(v, f[keep], process=False, validate=False)
    out.remove_unreferenced_vertices()
    return out, fixed, int((~keep).sum()), ids[keep]


def tilted_normals(mesh: trimesh.Trimesh, before: np.ndarray, moved: float) -> np.ndarray:
    """The normals (f, 3) the faces of a repaired ``mesh`` had before the repair (``before``:
    those of the faces they came from) where the repair tilted a face by more than round-off
    (1e-12) but no more than moving its corners by ``moved`` can (twice that over its
    smallest height: merging a sliver's corners, or welding, leaves the face in its
    triangle's plane to the coordinates' precision), and did not fold it over; NaN
    elsewhere, so untouched faces keep their normals bit for bit. A small face may be tilted
    by degrees (15.7 on a V-HACD Lego brick): its own normal then says little, its
    triangle's is the file's."""
    own, area = face_geometry(mesh)  # (trimesh's, with the zero of the part's size)
    tri = np.asarray(mesh.triangles, float)
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    height = 2.0 * area / np.maximum(longest, 1e-300)
    tilt = np.linalg.norm(own - before, axis=1)
    within = ((tilt > 1e-12) & (tilt <= 2.0 * moved / np.maximum(height, 1e-300))
              & (np.einsum("ij,ij->i", own, before) > 0))  # not folded over, and not from a
    # degenerate face (which has no normal: a zero vector)
    return np.where(within[:, None], before, np.nan)


def face_keys(mesh: trimesh.Trimesh, faces: np.ndarray | None = None) -> np.ndarray:
    """A key per face (or per face of ``faces``) that names it by its corners' coordinates
    whatever their order: the three corners sorted, as bytes. Faces the later repairs keep
    are found again by it, however they renumber vertices and faces or turn windings."""
    tri = np.asarray(mesh.triangles, float)
    if faces is not None:
        tri = tri[faces]
    order = np.lexsort((tri[:, :, 2], tri[:, :, 1], tri[:, :, 0]), axis=1)
    rows = np.ascontiguousarray(np.take_along_axis(tri, order[..., None], axis=1)
                                .reshape(len(tri), 9))
    return rows.view(np.dtype((np.void, 72))).ravel()


def drop_duplicate_faces(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, int]:
    """Drop repeated faces with the same orientation. Two coincident faces of opposite
    orientation are the touching sides of two bodies and are kept."""
    f = np.asarray(mesh.faces, np.int64)
    first = np.argmin(f, axis=1)
    # rotate each row to start at its smallest index (keeps the orientation)
    rolled = np.take_along_axis(f, (first[:, None] + np.arange(3)) % 3, axis=1)
    n = len(mesh.vertices)
    if float(n) ** 3 < 2.0**62:  # each row as one exact key: none repeated, nothing to do
        key = np.sort((rolled[:, 0] * n + rolled[:, 1]) * n + rolled[:, 2])
        if not (key[1:] == key[:-1]).any():
            return mesh, 0
    merged = _merge_rows(rolled)  # the first of each repeated row (as np.unique's index)
    keep = np.unique(rolled, axis=0, return_index=True)[1] if merged is None else merged[0]
    if len(keep) == len(f):
        return mesh, 0
    keep = np.sort(keep)
    out = trimesh.Trimesh(np.asarray(mesh.vertices, float), f[keep], process=False,
                          validate=False)
    return out, len(f) - len(keep)


def fix_winding(mesh: trimesh.Trimesh) -> None:
    """Wind every connected piece of ``mesh`` (faces joined by shared edges) like its first
    face, in place: trimesh's ``fix_winding``, whose walk over the faces' adjacency is a
    Python loop (2.7 s to load an 82k-face mesh with inconsistent winding, against 0.3 s), as
    array operations.

    Each face of a breadth-first tree of the adjacency is turned when its parent, once
    turned as it must be, runs their shared edge the same way; whether it must be is the
    parity of such edges on its path to the tree's root, found by pointer doubling. The
    root of each piece is the first face of the piece in ``mesh.face_adjacency``, where
    trimesh starts a mesh of one piece (the loader orients one piece at a time); on an
    orientable piece whose edges join two faces each, every tree gives the winding
    trimesh's walk gives. Of several pieces, trimesh starts a small one from the first face
    its set of faces yields, so an open piece may come out wound the other way round (a
    closed one is then turned outward by its volume in both).
    """
    if mesh.is_winding_consistent:
        return
    faces = np.array(mesh.faces, np.int64)
    n = len(faces)
    adj = np.asarray(mesh.face_adjacency, np.int64).reshape(-1, 2)
    # one root per piece (body_labels: the components of this adjacency): the first face of
    # the piece in the adjacency's order, joined to a node of its own (n), from which one
    # breadth-first walk reaches every piece
    first = adj.ravel()
    roots = first[np.unique(body_labels(mesh)[first], return_index=True)[1]]
    rows = np.concatenate([adj[:, 0], np.full(len(roots), n)])
    cols = np.concatenate([adj[:, 1], roots])
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(n + 1, n + 1))
    order, parent = breadth_first_order(graph.tocsr(), n, directed=False,
                                        return_predecessors=True)
    child = order[1:][order[1:] < n]
    child = child[parent[child] < n]  # the roots keep their winding
    up = parent[child]
    # the shared edge's corners: their slots in the child and in its parent
    below, above = faces[child], faces[up]
    match = below[:, :, None] == above[:, None, :]  # (m, 3, 3)

    def tail(rows: np.ndarray, shared: np.ndarray) -> np.ndarray:
        """The corner the face runs the shared edge from: slots (0, 1) and (1, 2) run it
        from the first, (0, 2) from slot 2 (the edge 2 -> 0)."""
        slot = np.where(shared[:, 0] & shared[:, 2], 2, np.argmax(shared, axis=1))
        return rows[np.arange(len(rows)), slot]

    same = tail(below, match.any(axis=2)) == tail(above, match.any(axis=1))
    turn = np.zeros(n + 1, bool)
    turn[child] = same
    hop = np.full(n + 1, n)
    hop[child] = up
    while (hop[child] != n).any():  # pointer doubling: the parity of the whole path
        turn[child] ^= turn[hop[child]]
        hop[child] = hop[hop[child]]
    flip = np.flatnonzero(turn[:n])
    if len(flip):
        faces[flip] = faces[flip, ::-1]
        mesh.faces = faces


def orient(mesh: trimesh.Trimesh, one_piece: bool = False) -> tuple[trimesh.Trimesh, int]:
    """Consistent winding and outward normals of every closed piece; returns the mesh and
    the faces flipped.

    ``one_piece``: the caller knows the mesh is one connected piece (the loader orients its
    pieces one at a time), which spares finding the pieces: a closed piece with a negative
    enclosed volume is then inside out (trimesh's ``fix_inversion`` without its second
    moments). Otherwise trimesh's ``fix_inversion`` turns each closed piece."""
    before = mesh.faces.copy()
    edge_closure(mesh)  # trimesh's closure answers, from the edge table the pieces came from
    fix_winding(mesh)
    if not one_piece and body_labels(mesh).max() > 0:
        trimesh.repair.fix_inversion(mesh, multibody=True)
    elif (len(mesh.faces) >= 4 and mesh.is_watertight and mesh.is_winding_consistent
            and mesh_moments(mesh)[0] < 0.0):
        mesh.invert()
        # trimesh's invert keeps the cached normals unturned when it cannot set the turned
        # ones (its setter checks them against the faces before it flips them): measured
        # again from the turned faces
        for key in ("face_normals", "vertex_normals"):
            mesh._cache.delete(key)
    return mesh, int((~(mesh.faces == before).all(axis=1)).sum())


def open_edges(mesh: trimesh.Trimesh) -> int:
    """Number of edges with one face."""
    return len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))


def close(mesh: trimesh.Trimesh, native: bool = True) -> tuple[trimesh.Trimesh, str | None]:
    """Try to close an open body; returns it and what was done (None: still open, and
    returned as it came: faces that close some holes but not all are not kept).

    trimesh fills the holes it can; failing that (and unless ``native`` is False),
    manifold3d merges nearly coincident open edges, in the child process of
    :mod:`synth.isolate` (it crashed on real meshes).

    Raises
    ------
    NativeCrash
        manifold3d crashed on this mesh; the caller keeps it open and says so.
    """
    n_f = len(mesh.faces)
    filled = mesh.copy()
    trimesh.repair.fill_holes(filled)
    if filled.is_watertight:
        filled, _ = orient(filled, one_piece=True)
        return filled, f"filled holes with {len(filled.faces) - n_f} faces"
    if not native:
        return mesh, None
    got = call_isolated(MERGE_CLOSE, np.asarray(mesh.vertices, np.float64),
                        np.asarray(mesh.faces, np.int64))
    if got is not None:
        vertices, faces = got
        closed = trimesh.Trimesh(vertices, faces, process=False)
        if closed.is_watertight and closed.volume > 0:
            return closed, "closed the mesh with manifold3d (merged open edges)"
    return mesh, None
