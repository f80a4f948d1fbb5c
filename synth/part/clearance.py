"""How far points on the surface lie from the part's sharp edges.

:meth:`synth.Part.resolve` calls a point a face contact when it is farther than the feature
tolerance from every sharp edge and corner *of its own face*. Two things make that answer
fragile for a point just beyond the tolerance:

* a sharp edge of another face can be nearer than the tolerance too, when the faces between
  them are narrower than it (a sliver beside a facet, a chamfer a few microns wide, the two
  triangles of a narrow strip);
* the mesh synth resolves on is the welded, repaired one, while a check of the grasp (or
  another tool) reads the file's own vertices, which can differ from it by round-off of the
  file's precision, so a point at the tolerance can be on either side of it.

A planner that keeps its contacts a few tolerances clear of every sharp edge returns contacts
that are face contacts on either mesh, with no normal left in doubt. The sharp edges here are
the convex, concave and open-boundary edges of :attr:`synth.Part.features` (a sharp corner
lies on them). They are cut into pieces no longer than ``1 / _PIECES`` of the part's length and
the pieces' midpoints put in a k-d tree, so that a query visits only the pieces near it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from synth.part.closest import closest_on_segments

__all__ = ["SharpEdges", "sharp_clearance"]

#: The sharp edges' pieces are at most the part's length over this.
_PIECES = 64


class SharpEdges:
    """The sharp edges of a mesh as short segments, for distance queries within a radius.

    Parameters
    ----------
    vertices : (v, 3) float
    edges : (e, 2) int
        Vertex pairs of the sharp edges.
    length : float
        The part's length: pieces are at most ``length / _PIECES`` long.
    """

    def __init__(self, vertices: NDArray[np.float64], edges: NDArray[np.int64],
                 length: float) -> None:
        a = np.asarray(vertices, np.float64)[edges[:, 0]]
        b = np.asarray(vertices, np.float64)[edges[:, 1]]
        span = np.linalg.norm(b - a, axis=1)
        step = length / _PIECES if length > 0 else 1.0
        cuts = np.maximum(1, np.ceil(span / step)).astype(np.int64)
        edge = np.repeat(np.arange(len(cuts)), cuts)
        first = np.cumsum(cuts) - cuts
        i = np.arange(len(edge)) - first[edge]  # the piece's number along its edge
        t0, t1 = (i / cuts[edge])[:, None], ((i + 1) / cuts[edge])[:, None]
        d = b[edge] - a[edge]
        # each piece's ends by interpolation from the edge's first end (its last piece ends on
        # the edge's other end exactly)
        self.start = a[edge] + t0 * d
        self.end = np.where(i[:, None] == cuts[edge, None] - 1, b[edge], a[edge] + t1 * d)
        mid = 0.5 * (self.start + self.end)
        self.reach = float(np.linalg.norm(self.end - self.start, axis=1).max() / 2) \
            if len(edge) else 0.0
        self._tree = cKDTree(mid) if len(edge) else None

    def distance(self, points: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
        """Distance (n,) from each point (n, 3) to the nearest sharp edge, where that is at
        most ``radius``; inf where no sharp edge comes that close."""
        q = np.asarray(points, np.float64).reshape(-1, 3)
        out = np.full(len(q), np.inf)
        if self._tree is None or not len(q):
            return out
        near = self._tree.query_ball_point(q, radius + self.reach)
        counts = np.array([len(x) for x in near], np.int64)
        if not counts.sum():
            return out
        owner = np.repeat(np.arange(len(q)), counts)
        piece = np.concatenate([np.asarray(x, np.int64) for x in near])
        p = q[owner]
        dist = np.linalg.norm(closest_on_segments(self.start[piece], self.end[piece], p) - p,
                              axis=1)
        np.minimum.at(out, owner, dist)
        out[out > radius] = np.inf
        return out


def sharp_clearance(part: Any, points: NDArray[np.float64], radius: float
                    ) -> NDArray[np.float64]:
    """Distance from each point to the part's nearest sharp edge, within ``radius``.

    Parameters
    ----------
    part : synth.Part
    points : (n, 3) float
    radius : float
        How far to look, in the part's units.

    Returns
    -------
    (n,) float
        The distance to the nearest convex, concave or open-boundary edge where it is at most
        ``radius``, else inf.
    """
    # kept on the part, not the mesh: two parts of one mesh can differ in their sharp edges
    # (``sharp_angle``)
    edges = part.__dict__.get("_synth_sharp_edges")
    if edges is None:
        feats = part.features
        edges = part.__dict__["_synth_sharp_edges"] = SharpEdges(
            part.mesh.vertices, feats.edges[feats.edge_kind != 0], float(part.length))
    return edges.distance(points, radius)
