"""The independent check itself: which faces a contact touches (tests/independent_check.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.independent_check import Pieces, point_triangle_distance
from tests.test_part_compound import _box, _obj


def test_touched_faces_skip_faces_buried_in_another_piece(tmp_path: Path) -> None:
    """A 2-cube ``A`` holds a box ``B`` flush with its x = 2 face; a box ``C`` sits outside on
    that face. On the seam where a side face of ``B`` (inside ``A``) meets ``A``'s face, only
    the faces of the plane x = 2 count; at the inside corner ``C`` makes with ``A``, ``C``'s
    side counts too."""
    path = _obj(tmp_path / "abc.obj", {
        "A": _box((2, 2, 2), (1, 1, 1)),
        "B": _box((1, 0.6, 0.6), (1.5, 0.5, 0.5)),
        "C": _box((1, 0.6, 0.6), (2.5, 1.5, 1.5)),
    })
    pieces = Pieces(path)
    assert len(pieces.closed) == 3
    outward = pieces.normals
    seam = pieces.touched(np.array([2.0, 0.2, 0.5]))  # on B's y = 0.2 face, inside A
    assert len(seam) and np.allclose(np.abs(outward[seam]), [1.0, 0.0, 0.0])
    p = np.array([2.0, 0.2, 0.5])
    near = point_triangle_distance(pieces.tri, np.broadcast_to(p, (len(pieces.tri), 3)))
    buried = np.flatnonzero((near <= pieces.tol) & np.isclose(outward, [0, -1, 0]).all(axis=1))
    assert len(buried) and not np.isin(buried, seam).any()  # within reach, but dropped
    corner = pieces.touched(np.array([2.0, 1.2, 1.5]))  # A's face and C's y = 1.2 side
    assert np.isclose(outward[corner], [0.0, -1.0, 0.0]).all(axis=1).any()
    assert np.isclose(np.abs(outward[corner]), [1.0, 0.0, 0.0]).all(axis=1).any()


def test_the_check_fails_grasps_that_hold_only_with_smooth_normals() -> None:
    """On a convex decomposition (CoACD's bottle), grasps planned with ``--surface smooth``
    pass the check as what they claim, but their d* overstates the one of the file's own
    facet normals: the check rejects them as grasps of the default model, and a reported
    d_star_mesh that is off is caught too."""
    from synth import PlanParams, load_part, plan_part
    from tests.independent_check import check_document

    path = Path(__file__).resolve().parent.parent / "meshes" / "corpus" / \
        "coacd_robosuite_bottle.obj"
    plan = plan_part(load_part(path, units="m"), PlanParams(evals=3000, top=1,
                                                           surface="smooth"))
    doc = plan.to_json()
    pieces = Pieces(path)
    assert check_document(path, doc, pieces) == []
    doc["params"]["surface"] = "both"
    failures = check_document(path, doc, pieces)
    assert failures and all(f.split(": ")[1].startswith("d* reported") or
                            "with the file's own normals" in f for f in failures), failures
    doc["params"]["surface"] = "smooth"
    doc["grasps"][0]["d_star_mesh"] += 1e-3
    assert check_document(path, doc, pieces) == ["grasp 1: d_star_mesh reported "
                                                 f"{doc['grasps'][0]['d_star_mesh']:.9f}, "
                                                 "scipy LP gives "
                                                 f"{doc['grasps'][0]['d_star_mesh'] - 1e-3:.9f}"]
