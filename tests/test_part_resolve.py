"""Normal resolution at known features, on tessellated curved surfaces, and closure checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import synth
from synth.contacts import sample_contacts
from synth.errors import InputError
from synth.part import Part, load_part

MESHES = Path(__file__).resolve().parent.parent / "meshes"
S2, S3 = 1.0 / np.sqrt(2.0), 1.0 / np.sqrt(3.0)


@pytest.fixture(scope="module")
def cube() -> Part:
    return load_part(MESHES / "cube.stl", units="decimeters")


@pytest.fixture(scope="module")
def bracket() -> Part:
    return load_part(MESHES / "bracket.stl", units="decimeters")


@pytest.fixture(scope="module")
def cylinder() -> Part:
    return load_part(MESHES / "cylinder.stl", units="decimeters")


def _inward(part: Part, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    step = 1e-4 * part.length
    return part.mesh.contains(points + step * normals)


# (point, expected kind, expected normals as rows, unique?, cone size)
CUBE_CASES = [
    ((0.0, 0.0, 0.5), "face", [(0, 0, -1)], True, 1),  # on the smooth face diagonal
    ((0.2, -0.1, -0.5), "face", [(0, 0, 1)], True, 1),
    ((0.5, 0.5, 0.1), "edge", [(-S2, -S2, 0)], False, 2),
    ((-0.5, 0.2, 0.5), "edge", [(S2, 0, -S2)], False, 2),
    ((0.5, 0.5, 0.5), "vertex", [(-S3, -S3, -S3)], False, 3),
    ((-0.5, 0.5, -0.5), "vertex", [(S3, -S3, S3)], False, 3),
]

BRACKET_CASES = [
    ((1.5, 0.5, 0.25), "face", [(0, 0, -1)], True, 1),
    ((2.0, 0.5, 0.25), "edge", [(-S2, 0, -S2)], False, 2),  # convex edge at the base's end
    ((2.0, 1.0, 0.25), "vertex", [(-S3, -S3, -S3)], False, 3),  # convex corner
    ((0.25, 0.6, 0.25), "edge", [(0, 0, -1), (-1, 0, 0)], True, 2),  # groove: 2 contacts
    ((0.6, 0.25, 0.25), "edge", [(0, 0, -1), (0, -1, 0)], True, 2),
    ((0.25, 0.25, 0.6), "edge", [(-1, 0, 0), (0, -1, 0)], True, 2),
    ((0.25, 0.25, 0.25), "vertex", [(-1, 0, 0), (0, -1, 0), (0, 0, -1)], True, 3),  # inside
]


def _check(part: Part, point: tuple, kind: str, normals: list, unique: bool, cone: int,
           via_face: bool) -> None:
    p = np.array([point], float)
    if via_face:
        # give the face explicitly: any face of the closest set must resolve the same
        _, _, face = trimesh.proximity.closest_point(part.mesh, p)
        c = part.resolve(p, np.asarray(face))
    else:
        c = part.resolve(p)
    assert len(c) == len(normals), (point, c.to_dict())
    assert set(c.features.tolist()) == {kind}
    assert (c.finger == 0).all() and c.n_fingers == 1
    got = sorted(map(tuple, np.round(c.normals, 9)))
    assert np.allclose(got, sorted(map(tuple, np.round(normals, 9))), atol=1e-7), point
    assert (c.unique_normal == unique).all()
    assert np.allclose(c.points, p, atol=1e-12)
    assert np.allclose(np.linalg.norm(c.normals, axis=1), 1.0)
    assert len(part.normal_cone(kind, int(c.feature_index[0]))) == cone
    if kind != "face":
        assert (c.feature_index == c.feature_index[0]).all()
    assert (c.region == part.face_region[c.faces]).all()
    assert _inward(part, c.points, c.normals).all()


@pytest.mark.parametrize("case", CUBE_CASES, ids=lambda c: f"{c[1]}{c[0]}")
@pytest.mark.parametrize("via_face", [False, True])
def test_cube_known_features(cube: Part, case: tuple, via_face: bool) -> None:
    _check(cube, *case, via_face=via_face)


@pytest.mark.parametrize("case", BRACKET_CASES, ids=lambda c: f"{c[1]}{c[0]}")
@pytest.mark.parametrize("via_face", [False, True])
def test_bracket_known_features(bracket: Part, case: tuple, via_face: bool) -> None:
    _check(bracket, *case, via_face=via_face)


def test_saddle_vertex_gives_one_contact_per_facet(bracket: Part) -> None:
    c = bracket.resolve([[0.25, 1.0, 0.25]])  # end of a groove on the outer side face
    assert len(c) == 3 and (c.features == "vertex").all() and not c.unique_normal.any()
    assert np.allclose(sorted(map(tuple, c.normals)), sorted([(0, -1, 0), (0, 0, -1),
                                                                (-1, 0, 0)]), atol=1e-9)


def test_fingers_group_contacts_of_one_point(bracket: Part) -> None:
    pts = [[1.5, 0.5, 0.25], [0.25, 0.25, 0.25], [0.25, 0.6, 0.25], [2.0, 0.5, 0.25]]
    c = bracket.resolve(pts)
    assert c.finger.tolist() == [0, 1, 1, 1, 2, 2, 3]


def test_off_surface_points_refused_or_snapped(cube: Part) -> None:
    with pytest.raises(InputError, match="farther than"):
        cube.resolve([[0.0, 0.0, 0.6]])
    c = cube.resolve([[0.0, 0.0, 0.6], [0.9, 0.9, 0.9], [0.1, 0.0, 0.0]], snap=True)
    assert np.allclose(c.points, [[0, 0, 0.5], [0.5, 0.5, 0.5], [0.5, 0.0, 0.0]])
    assert c.features.tolist() == ["face", "vertex", "face"]
    with pytest.raises(InputError, match="shape"):
        cube.resolve(np.zeros((2, 2)))
    with pytest.raises(InputError, match="finite"):
        cube.resolve([[np.nan, 0, 0]])
    with pytest.raises(InputError, match="faces"):
        cube.resolve([[0, 0, 0.5]], np.array([99]))


def _true_cylinder_normals(points: np.ndarray) -> np.ndarray:
    n = -np.c_[points[:, :2], np.zeros(len(points))]
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_cylinder_side_normals_follow_the_cylinder(cylinder: Part) -> None:
    """The smooth reading follows the cylinder the facets approximate; the mesh reading is
    the facets' own normal."""
    c = sample_contacts(cylinder, 3000, seed=3)
    side = np.abs(c.smooth_normals[:, 2]) < 0.5
    assert side.sum() > 1500
    true = _true_cylinder_normals(c.points[side])
    err = np.arccos(np.clip(np.einsum("ij,ij->i", true, c.smooth_normals[side]), -1, 1))
    facet = 2 * np.pi / 64  # angle between neighbouring side facets
    assert err.max() < facet / 2
    # and much better than the raw face normals, which are off by up to facet / 2
    face_in = -cylinder.mesh.face_normals[c.faces[side]]
    face_err = np.arccos(np.clip(np.einsum("ij,ij->i", true, face_in), -1, 1))
    assert err.mean() < 0.01 * face_err.mean()
    # the mesh reading: exactly the facet's normal, which is off by up to facet / 2
    assert np.allclose(c.normals[side], face_in, rtol=0, atol=1e-12)
    assert face_err.max() > 0.9 * facet / 2
    # continuity across smooth edges: nearby points on both sides of an edge agree
    e = cylinder.features.edges_of_kind("smooth")
    v = np.asarray(cylinder.mesh.vertices)
    vert = e[np.abs(v[cylinder.features.edges[e, 0], 2] - v[cylinder.features.edges[e, 1], 2])
             > 1.0]  # the long vertical edges between side facets
    mid = v[cylinder.features.edges[vert]].mean(axis=1)
    offs = 1e-5 * np.cross(_true_cylinder_normals(mid), [0, 0, 1])
    a = cylinder.resolve(mid + offs, snap=True).smooth_normals
    b = cylinder.resolve(mid - offs, snap=True).smooth_normals
    assert np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1)).max() < 1e-4


def _random_sets(c: synth.Contacts, n_sets: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.choice(len(c), rng.integers(7, 13), replace=False) for _ in range(n_sets)]


def _form_closure_count(part: Part, n_sets: int = 150) -> int:
    """Form-closure sets among random ones, scored with the smooth reading (a surface of
    revolution, which no frictionless grasp holds)."""
    c = sample_contacts(part, 2000, seed=5)
    assert (np.abs(c.smooth_normals[:, 2]) > 0.99).any()  # caps included
    return sum(
        synth.form_closure(synth.wrench_matrix(c.points[i], c.smooth_normals[i])).closure
        == "form"
        for i in _random_sets(c, n_sets, seed=6)
    )


def test_form_closure_never_on_a_cylinder_in_double_precision() -> None:
    part = load_part(trimesh.creation.cylinder(radius=0.5, height=1.5, sections=64))
    assert _form_closure_count(part) == 0


def test_form_closure_never_on_the_float32_cylinder_stl(cylinder: Part) -> None:
    # float32 coordinates: normals exact to ~1e-7 rad; synth.tolerances.RANK_RTOL is set above that
    assert _form_closure_count(cylinder) == 0


ALL_MESHES = ["cube", "prism", "bracket", "tee", "nut", "cylinder", "sphere", "torus"]


def _query_points(part: Part, rng: np.random.Generator) -> np.ndarray:
    """On the surface, just off it (inside the tolerances and well beyond), at vertices and
    edge midpoints (ties between faces), and far away."""
    m = part.mesh
    s, fi = trimesh.sample.sample_surface(m, 150, seed=int(rng.integers(1 << 30)))
    nrm = m.face_normals[fi]
    size = part.length
    scales = np.r_[np.zeros(30), rng.uniform(-1, 1, 40) * part.surface_tolerance,
                   rng.normal(size=80) * 1e-3 * size]
    v = m.vertices[rng.integers(0, len(m.vertices), 30)]
    e = m.vertices[m.edges_unique[rng.integers(0, len(m.edges_unique), 30)]].mean(axis=1)
    far = m.bounds.mean(axis=0) + rng.normal(size=(30, 3)) * size
    near = np.r_[v, e] + rng.normal(size=(60, 3)) * 1e-2 * size
    return np.r_[s + scales[:, None] * nrm, v, e, near, far]


def _brute(part: Part, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance to every face (n, f) and the minimum (n,)."""
    from synth.part.closest import closest_on_triangles

    tri = np.asarray(part.mesh.vertices, float)[np.asarray(part.mesh.faces)]
    d = np.empty((len(points), len(tri)))
    for i, p in enumerate(points):
        q = closest_on_triangles(tri, np.broadcast_to(p, (len(tri), 3)))
        d[i] = np.linalg.norm(q - p, axis=1)
    return d, d.min(axis=1)


def _fine_torus() -> Part:
    import manifold3d as mf

    m = mf.Manifold.revolve(mf.CrossSection.circle(0.2, 40).translate((0.6, 0.0)), 100)
    mesh = m.to_mesh()
    return Part(trimesh.Trimesh(np.asarray(mesh.vert_properties, float)[:, :3],
                                np.asarray(mesh.tri_verts, np.int64)))


def _closest_reference(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Closest points by a different route: the plane projection when it falls inside the
    triangle (by signed areas), else the nearest of the three edge segments."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    q = p - np.einsum("ij,ij->i", p - a, n)[:, None] * n
    inside = np.ones(len(p), bool)
    best = np.full(len(p), np.inf)
    out = q.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= 0
        t = np.clip(np.einsum("ij,ij->i", p - u, v - u) / np.einsum("ij,ij->i", v - u, v - u),
                    0, 1)
        e = u + t[:, None] * (v - u)
        d = np.linalg.norm(e - p, axis=1)
        closer = d < best
        best[closer], out[closer] = d[closer], e[closer]
    out[inside] = q[inside]
    return out


@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-3, 0.0), (1e-2, 5.0), (1e3, 1e6),
                                           (1e-3, 1.0)])
def test_closest_kernel_exact_at_any_scale_and_placement(scale: float, offset: float) -> None:
    """Points inside thin triangles stay inside at any unit and placement (an absolute zero in
    the region tests sent them to a vertex for parts in metres)."""
    from synth.part.closest import closest_on_triangles

    rng = np.random.default_rng(3)
    tri = rng.normal(size=(6000, 3, 3))
    tri[:2000, 2] = tri[:2000, 0] + 1e-3 * (tri[:2000, 2] - tri[:2000, 0])  # slivers
    w = rng.dirichlet([1, 1, 1], size=6000)
    inside = np.einsum("ij,ijk->ik", w, tri)
    p = np.r_[rng.normal(size=(3000, 3)) * 2, inside[3000:]]
    tri, p = tri * scale + offset, p * scale + offset
    q = closest_on_triangles(tri, p)
    ref = _closest_reference(tri, p)
    size = scale * np.sqrt(3)
    d, d_ref = np.linalg.norm(q - p, axis=1), np.linalg.norm(ref - p, axis=1)
    # float64 round-off of the coordinates (offset) and of the geometry (scale)
    err = 1e-12 * size + 1e-14 * abs(offset)
    assert np.all(d <= d_ref + err)
    assert np.all(np.abs(d - d_ref) <= err)
    assert np.all(d[3000:] <= err)  # points on the triangle are their own closest point


@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-3, 1.0), (1e3, 1e6)])
def test_closest_kernel_on_needles(scale: float, offset: float) -> None:
    """Needles, one edge a millionth of the others: points on them are their own closest point
    to within the needle's width, points off them get the nearest of their edges' closest points.

    The short edge's region test passed for every point and sent it to a corner: robosuite's
    soccer goal has a needle 1e-8 wide and 0.011 long, and points on it were put 1.5e-3 away.
    """
    from synth.part.closest import closest_on_triangles

    rng = np.random.default_rng(5)
    n = 3000
    a, b = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    # the short edge c-a across the long ones, as a needle's is (its region test then sees
    # dot products with c - a of nothing but round-off)
    across = np.cross(b - a, rng.normal(size=(n, 3)))
    c = a + 1e-6 * across / np.linalg.norm(across, axis=1, keepdims=True)
    tri = np.stack([a, b, c], axis=1)
    on = np.einsum("ij,ijk->ik", rng.dirichlet([1, 1, 1], size=n), tri)
    off = on + rng.normal(size=(n, 3))
    tri, on, off = tri * scale + offset, on * scale + offset, off * scale + offset
    width = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / \
        np.linalg.norm(tri[:, 1] - tri[:, 0], axis=1)  # twice the area over the long edge
    err = 1e-12 * scale + 1e-14 * abs(offset)
    d_on = np.linalg.norm(closest_on_triangles(tri, on) - on, axis=1)
    assert np.all(d_on <= width + err)
    q = closest_on_triangles(tri, off)
    d, d_ref = np.linalg.norm(q - off, axis=1), np.linalg.norm(_closest_reference(tri, off) - off,
                                                               axis=1)
    assert np.all(np.abs(d - d_ref) <= width + err)


@pytest.mark.parametrize("name", [*ALL_MESHES, "fine_torus"])
def test_closest_points_exact(name: str) -> None:
    """Against a brute force over all faces and trimesh.proximity.closest_point."""
    from synth.part.resolve import closest_points

    part = _fine_torus() if name == "fine_torus" else \
        load_part(MESHES / f"{name}.stl", units="decimeters")
    pts = _query_points(part, np.random.default_rng(8))
    q, f, d = closest_points(part, pts)
    all_d, best = _brute(part, pts)
    rows = np.arange(len(pts))
    eps = 1e-12 * part.length
    assert np.all(np.abs(d - best) <= eps)
    # the returned point lies on the returned face, at the returned distance
    assert np.allclose(np.linalg.norm(q - pts, axis=1), d, rtol=0, atol=eps)
    assert np.all(np.abs(all_d[rows, f] - d) <= eps)
    # trimesh: same distances and points except where its near-tie rule (squared distances
    # within tol.merge) took a slightly farther face; faces differ only on ties
    c_tm, d_tm, f_tm = trimesh.proximity.closest_point(part.mesh, pts)
    assert np.all(d <= d_tm + eps)
    swapped = np.abs(d - d_tm) > eps
    assert np.all(d_tm[swapped] ** 2 - d[swapped] ** 2 < trimesh.tol.merge)
    same = ~swapped
    assert np.allclose(q[same], c_tm[same], rtol=0, atol=eps)
    other = same & (f != f_tm)
    assert np.all(np.abs(all_d[rows, f_tm] - all_d[rows, f])[other] <= eps)
    # the contacts: resolving the exact points with the brute-force face (the first of
    # tied faces) gives the same points and normals (ties: the point is on a feature the
    # faces share)
    c = part.resolve(pts, snap=True)
    bf_face = np.argmin(all_d, axis=1)
    c_bf = part.resolve(q, bf_face, snap=True)
    assert np.array_equal(c.finger, c_bf.finger)
    assert np.allclose(c.points, c_bf.points, rtol=0, atol=1e-12 * part.length)
    assert np.allclose(c.normals, c_bf.normals, rtol=0, atol=1e-12)


def test_box_tree_exact_beside_slivers_against_brute_force() -> None:
    """Exact distances, points and faces, on a mesh with long slivers that span far beyond
    the small faces, at points near and far (brute force over every face)."""
    from synth.part.closest import BoxTree

    mesh = trimesh.creation.box((1.0, 1.0, 1.0)).subdivide().subdivide()
    sliver = trimesh.Trimesh([[-5, 2, 0], [5, 2, 0], [0, 2.001, 0.0]], [[0, 1, 2]])
    mesh = trimesh.util.concatenate([mesh, sliver])
    tree = BoxTree(mesh.vertices, mesh.faces)
    rng = np.random.default_rng(5)
    pts = np.r_[rng.uniform(-1, 1, size=(2500, 3)),
                rng.uniform([-6, 1.7, -0.3], [6, 2.3, 0.3], size=(500, 3))]
    q, f, d = tree.closest(pts)
    tri = np.asarray(mesh.triangles)
    all_d = np.array([np.linalg.norm(trimesh.triangles.closest_point(
        tri, np.broadcast_to(p, (len(tri), 3))) - p, axis=1) for p in pts])
    brute = all_d.min(axis=1)
    assert np.allclose(d, brute, rtol=0, atol=1e-12)
    assert np.allclose(all_d[np.arange(len(pts)), f], d, rtol=0, atol=1e-12)
    assert np.allclose(np.linalg.norm(q - pts, axis=1), d, atol=1e-12)
    assert np.allclose(tree.distance(pts), brute, rtol=0, atol=1e-12)
    assert (f == len(tri) - 1).sum() > 100  # the sliver is the answer for many points


@pytest.mark.parametrize("scale", [1e-4, 1e-3, 1.0, 1e3])
def test_box_tree_first_hits_against_trimesh_at_any_scale(scale: float) -> None:
    """The first face each ray meets ahead of its origin, and how far: libigl's single
    precision ray test (scale free through its rays' lengths) against trimesh's rays
    (every hit, the nearest ahead kept), on a fine ring scaled from 0.1 mm to 1 km, from
    inside its wall (a millionth of its size behind a face) and from outside."""
    from synth.part.closest import BoxTree

    ring = trimesh.creation.annulus(r_min=0.98, r_max=1.0, height=0.5, sections=200)
    ring.apply_scale(scale)
    tree = BoxTree(ring.vertices, ring.faces)
    tri = np.asarray(ring.triangles)
    n = np.asarray(ring.face_normals)
    length = float(np.linalg.norm(ring.extents))
    rng = np.random.default_rng(3)
    pick = rng.choice(len(tri), 300, replace=False)
    o = np.r_[tri[pick].mean(axis=1) - 1e-6 * length * n[pick],
              rng.uniform(-1.5, 1.5, size=(300, 3)) * scale]
    d = np.r_[-n[pick], rng.normal(size=(300, 3))]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    face, dist = tree.first_hits(o, d)
    unit = trimesh.Trimesh(ring.vertices / scale, ring.faces)  # trimesh's tolerances are absolute
    loc, ray, tri_id = unit.ray.intersects_location(o / scale, d, multiple_hits=True)
    ahead = np.einsum("ij,ij->i", loc - o[ray] / scale, d[ray])
    keep = ahead > 1e-6 * length / scale
    want = np.full(len(o), np.inf)
    np.minimum.at(want, ray[keep], ahead[keep] * scale)
    hit = np.isfinite(want)
    assert hit[:300].all() and 20 < hit[300:].sum() < 300  # every wall; some others (38)
    assert np.array_equal(face >= 0, hit)
    assert np.allclose(dist[hit], want[hit], rtol=1e-6, atol=0)
    assert np.all(dist[~hit] == np.inf)


@pytest.mark.parametrize(("scale", "offset"), [(1e-3, 0.0), (1.0, 0.0), (1e3, 0.0),
                                               (1.0, 1e4)])
def test_distance_bound_never_exceeds_the_distance(scale: float, offset: float) -> None:
    """``DistanceBound`` is a lower bound of the exact distance (brute force over every face)
    at any size and placement, near the surface and far from it, on a mesh with a long
    sliver beside small faces; and within twice its slack of the distance."""
    from synth.part.closest import DistanceBound

    mesh = trimesh.creation.torus(1.0, 0.3, major_sections=48, minor_sections=16)
    sliver = trimesh.Trimesh([[-3, 2, 0], [3, 2, 0], [0, 2.001, 0.0]], [[0, 1, 2]])
    mesh = trimesh.util.concatenate([mesh, sliver])
    mesh.vertices = mesh.vertices * scale + offset
    rng = np.random.default_rng(11)
    pts = np.r_[rng.uniform(-2, 2, size=(1500, 3)), rng.uniform(-20, 20, size=(500, 3))]
    pts = pts * scale + offset
    bound = DistanceBound(mesh.vertices, mesh.faces, cells=16)
    tri = np.asarray(mesh.triangles)
    exact = np.array([np.linalg.norm(trimesh.triangles.closest_point(
        tri, np.broadcast_to(p, (len(tri), 3))) - p, axis=1).min() for p in pts])
    lb = bound(pts)
    assert np.all(lb <= exact)
    assert np.all(exact - lb <= 2 * bound.radius * (1 + 1e-9))
    assert (lb > 0.5 * exact)[1500:].mean() > 0.9  # and it is not vacuous far out
    # on the surface: the corners themselves, at distance 0
    assert np.all(bound(np.asarray(mesh.vertices)) <= 0.0)
    # a mesh with no faces has no bound
    assert np.all(DistanceBound(mesh.vertices, np.zeros((0, 3), int))(pts) == -np.inf)


def test_a_part_pickles_and_answers_the_same_after() -> None:
    """A Part travels to other processes (multiprocessing, Dask): its libigl tree pickles as
    its arrays and is built again on first use."""
    import pickle

    from synth import PlanParams, load_part, plan_part

    part = load_part(MESHES / "tee.stl")
    copy = pickle.loads(pickle.dumps(part))
    pts = np.random.default_rng(2).uniform(-1.0, 1.0, size=(200, 3)) * part.length
    assert np.array_equal(copy.surface_distance(pts), part.surface_distance(pts))
    a = plan_part(part, PlanParams(seed=0, evals=2000))
    b = plan_part(copy, PlanParams(seed=0, evals=2000))
    assert [g.d_star for g in a.grasps] == [g.d_star for g in b.grasps]
    assert all(np.array_equal(g.points, h.points) for g, h in zip(a.grasps, b.grasps,
                                                                   strict=True))
