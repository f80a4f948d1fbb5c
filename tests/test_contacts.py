"""Contacts: the result type, sampling invariants on every sample mesh, and rays."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.contacts import SAMPLE_METHODS, Contacts, contacts_from_rays, sample_contacts
from synth.errors import InputError
from synth.part import Part, load_part

MESHES = Path(__file__).resolve().parent.parent / "meshes"
NAMES = ["cube", "prism", "bracket", "tee", "nut", "cylinder", "sphere", "torus"]


@pytest.fixture(scope="module")
def parts() -> dict[str, Part]:
    return {n: load_part(MESHES / f"{n}.stl", units="decimeters") for n in NAMES}


def _assert_valid(part: Part, c: Contacts) -> None:
    """Independent checks: on the surface (trimesh.proximity) and normals point inside."""
    _, dist, _ = trimesh.proximity.closest_point(part.mesh, c.points)
    assert dist.max() < 1e-9 * part.length
    step = 1e-4 * part.length
    # a contact sharing its finger (groove, inside corner, saddle) carries the normal of its
    # own face: test it from a point moved slightly into that face
    shared = np.bincount(c.finger)[c.finger] > 1
    centre = part.mesh.triangles_center[c.faces]
    start = np.where(shared[:, None], c.points + 1e-3 * (centre - c.points), c.points)
    assert part.mesh.contains(start + step * c.normals).all()
    assert not part.mesh.contains(c.points - step * c.normals)[c.features == "face"].any()
    assert np.allclose(np.linalg.norm(c.normals, axis=1), 1.0)
    assert (c.region == part.face_region[c.faces]).all()


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("method", ["uniform", "even", "regions"])
def test_surface_samples_on_surface_and_inward(parts: dict[str, Part], name: str,
                                               method: str) -> None:
    part = parts[name]
    c = sample_contacts(part, 300, seed=11, method=method)
    assert c.n_fingers == 300
    _assert_valid(part, c)


@pytest.mark.parametrize("name", ["cube", "prism", "bracket", "tee", "nut", "cylinder"])
@pytest.mark.parametrize("method", ["edges", "corners"])
def test_feature_samples(parts: dict[str, Part], name: str, method: str) -> None:
    part = parts[name]
    if method == "corners" and name == "cylinder":
        with pytest.raises(InputError, match="no corners"):
            sample_contacts(part, 5, seed=0, method=method)
        return
    c = sample_contacts(part, 40, seed=2, method=method)
    assert c.n_fingers == 40 and len(c) >= 40
    want = "edge" if method == "edges" else "vertex"
    assert (c.features == want).all()
    _assert_valid(part, c)
    # concave features give several contacts per finger
    per = np.bincount(c.finger)
    if name == "bracket" and method == "edges":
        assert per.max() == 2 and per.min() == 1


def test_sampling_is_reproducible_and_seeded(parts: dict[str, Part]) -> None:
    part = parts["bracket"]
    for method in SAMPLE_METHODS:
        a = sample_contacts(part, 50, seed=7, method=method)
        b = sample_contacts(part, 50, seed=np.random.default_rng(7), method=method)
        assert a.to_dict() == b.to_dict(), method
    c = sample_contacts(part, 50, seed=8)
    assert not np.allclose(c.points, sample_contacts(part, 50, seed=7).points)


def test_uniform_is_area_uniform(parts: dict[str, Part]) -> None:
    part = parts["bracket"]
    c = sample_contacts(part, 20000, seed=1)
    area = np.array([r.area for r in part.regions])
    share = np.bincount(c.region, minlength=len(area)) / len(c)
    expected = area / area.sum()
    sigma = np.sqrt(expected * (1 - expected) / len(c))
    assert (np.abs(share - expected) < 5 * sigma + 1e-12).all()


def test_regions_method_gives_every_region_an_equal_share(parts: dict[str, Part]) -> None:
    # the nut: 14 regions whose areas differ 7-fold; by region each gets 1 / 14
    part = parts["nut"]
    n = 20000
    c = sample_contacts(part, n, seed=3, method="regions")
    count = np.bincount(c.region, minlength=len(part.regions))
    p = 1 / len(part.regions)
    sigma = np.sqrt(p * (1 - p) / n)
    assert (np.abs(count / n - p) < 5 * sigma).all()
    area = np.array([r.area for r in part.regions])
    # the test means something: area-uniform shares would fail it by far
    assert (np.abs(area / area.sum() - p) > 20 * sigma).any()
    # within one region the points stay area-uniform over its faces
    big = int(np.argmax(area))
    faces = part.regions[big].faces
    fa = np.asarray(part.mesh.area_faces)[faces]
    got = np.array([(c.faces == f).sum() for f in faces])
    want = got.sum() * fa / fa.sum()
    assert (np.abs(got - want) < 5 * np.sqrt(want) + 1).all()
    sub = sample_contacts(part, 300, seed=3, method="regions", regions=[big])
    assert (sub.region == big).all()


def test_even_spread_beats_uniform(parts: dict[str, Part]) -> None:
    part = parts["sphere"]

    def min_gap(c: Contacts) -> float:
        d = np.linalg.norm(c.points[:, None] - c.points[None], axis=2)
        return float(d[np.triu_indices(len(c), 1)].min())

    even = sample_contacts(part, 200, seed=4, method="even")
    uni = sample_contacts(part, 200, seed=4, method="uniform")
    assert min_gap(even) > 3 * min_gap(uni)


def test_region_restriction(parts: dict[str, Part]) -> None:
    part = parts["nut"]
    curved = [r.index for r in part.regions if not r.planar]
    c = sample_contacts(part, 200, seed=0, regions=curved)
    assert np.isin(c.region, curved).all()
    _assert_valid(part, c)
    with pytest.raises(InputError, match="regions"):
        sample_contacts(part, 5, seed=0, regions=[999])
    with pytest.raises(InputError, match="method"):
        sample_contacts(part, 5, seed=0, method="magic")


def test_contacts_type_frozen_select_concatenate(parts: dict[str, Part]) -> None:
    part = parts["bracket"]
    c = part.resolve([[0.25, 0.25, 0.25], [1.5, 0.5, 0.25]])
    assert len(c) == 4
    with pytest.raises(ValueError):
        c.points[0, 0] = 1.0
    with pytest.raises(AttributeError):
        c.points = np.zeros((4, 3))  # type: ignore[misc]
    sel = c.select(c.features == "face")
    assert len(sel) == 1 and sel.finger.tolist() == [1]
    both = Contacts.concatenate([c, c])
    assert len(both) == 8 and both.n_fingers == 4
    assert both.finger.tolist() == [0, 0, 0, 1, 2, 2, 2, 3]
    d = json.loads(json.dumps(c.to_dict()))
    assert Contacts(**d).to_dict() == c.to_dict()
    with pytest.raises(InputError, match="features"):
        Contacts(**{**d, "features": ["face", "rim", "face", "face"]})
    with pytest.raises(InputError, match="shape"):
        Contacts(**{**d, "normals": [[0, 0, 1]]})


def test_rays(parts: dict[str, Part]) -> None:
    cube = parts["cube"]
    origins = [[0.1, 0.2, 3.0], [0.5, 0.5, 3.0], [5.0, 5.0, 5.0], [3.0, 0.0, 0.0]]
    dirs = [[0, 0, -1], [0, 0, -1], [0, 0, 1], [-2, 0, 0]]
    c = contacts_from_rays(cube, origins, dirs)
    assert c.finger.tolist() == [0, 1, 3]  # ray 2 misses
    assert np.allclose(c.points, [[0.1, 0.2, 0.5], [0.5, 0.5, 0.5], [0.5, 0.0, 0.0]])
    assert c.features.tolist() == ["face", "vertex", "face"]
    assert np.allclose(c.normals[[0, 2]], [[0, 0, -1], [-1, 0, 0]])
    same = cube.raycast(origins, dirs)
    assert same.to_dict() == c.to_dict()
    # a finger coming down into the bracket's groove touches both faces
    g = contacts_from_rays(parts["bracket"], [[1.0, 0.6, 1.25]], [[-0.75, 0.0, -1.0]])
    assert len(g) == 2 and (g.finger == 0).all() and (g.features == "edge").all()
    with pytest.raises(InputError, match="zero length"):
        contacts_from_rays(cube, [[0, 0, 2.0]], [[0, 0, 0]])


def _ray_cases(part: Part, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Random rays, rays aimed at vertices and edge midpoints (ties between faces),
    axis-aligned rays and rays starting on or inside the surface."""
    m = part.mesh
    c, size = m.bounds.mean(axis=0), part.length
    o1 = c + rng.normal(size=(150, 3)) * size
    d1 = c + rng.normal(size=(150, 3)) * 0.2 * size - o1
    v = m.vertices[rng.integers(0, len(m.vertices), 60)]
    e = m.vertices[m.edges_unique[rng.integers(0, len(m.edges_unique), 60)]].mean(axis=1)
    tgt = np.r_[v, e]
    o2 = tgt + rng.normal(size=tgt.shape) * size
    o3 = c + rng.uniform(-0.5, 0.5, (60, 3)) * m.extents
    ax = rng.integers(0, 3, 60)
    o3[np.arange(60), ax] = c[ax] + 2 * size
    d3 = np.zeros((60, 3))
    d3[np.arange(60), ax] = -1.0
    s, _ = trimesh.sample.sample_surface(m, 40, seed=3)
    o4 = np.r_[s, c + rng.normal(size=(40, 3)) * 0.1 * size]
    o = np.r_[o1, o2, o3, o4]
    d = np.r_[d1, tgt - o2, d3, rng.normal(size=(80, 3))]
    return o, d / np.linalg.norm(d, axis=1)[:, None]


@pytest.mark.parametrize("name", NAMES)
def test_first_hits_identical_to_trimesh(parts: dict[str, Part], name: str) -> None:
    from synth.contacts.rays import _first_hits_trimesh, first_hits

    part = parts[name]
    o, d = _ray_cases(part, np.random.default_rng(5))
    loc, ray, tri = first_hits(part, o, d)
    loc0, ray0, tri0 = _first_hits_trimesh(part, o, d)
    assert len(ray) > 100
    assert np.array_equal(ray, ray0) and np.array_equal(tri, tri0)
    assert np.array_equal(loc, loc0)


def test_first_hits_fine_mesh_matches_brute_force() -> None:
    """A 8k-face torus, rays in every direction: same faces and points as trimesh."""
    import manifold3d as mf

    from synth.contacts.rays import _first_hits_trimesh, first_hits

    m = mf.Manifold.revolve(mf.CrossSection.circle(0.2, 40).translate((0.6, 0.0)), 100)
    mesh = m.to_mesh()
    part = Part(trimesh.Trimesh(np.asarray(mesh.vert_properties, float)[:, :3],
                                np.asarray(mesh.tri_verts, np.int64)))
    o, d = _ray_cases(part, np.random.default_rng(6))
    a, b = first_hits(part, o, d), _first_hits_trimesh(part, o, d)
    assert len(a[1]) > 100
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)


def test_sampling_arguments_are_checked_by_name():
    """No part, a trillion contacts, a count given as text, a negative seed: each an
    InputError naming its argument (they were numpy's errors, or memory exhausted)."""
    from synth import load_part, sample_contacts
    from synth.errors import InputError

    part = load_part(MESHES / "cube.stl")
    cases = [((None, 10), {}, "part"), ((part, 10**12), {}, "n"), ((part, "5"), {}, "n"),
             ((part, 10), {"seed": -1}, "seed")]
    for args, kw, word in cases:
        with pytest.raises(InputError, match=f"^{word}: expected"):
            sample_contacts(*args, **kw)


def test_ray_and_query_arguments_are_checked_by_name():
    """No part, no origins, a (2,) vector, text, NaN, a row count that differs: each an
    InputError naming the argument (they were numpy's reshape or broadcast errors)."""
    from synth import contacts_from_rays, load_part
    from synth.errors import InputError

    part = load_part(MESHES / "torus.stl")  # two sides: the exposure test runs
    with pytest.raises(InputError, match="^contacts_from_rays: part must be a synth Part"):
        contacts_from_rays(None, [[0, 0, 5.0]], [[0, 0, -1.0]])
    cases = [
        (lambda: contacts_from_rays(part, None, None), "^origins: expected shape"),
        (lambda: contacts_from_rays(part, [1, 2], [1, 2]), r"^origins: expected shape \(n, 3\)"),
        (lambda: contacts_from_rays(part, "a", "b"), "^origins: expected an"),
        (lambda: contacts_from_rays(part, [[0, 0, 5.0]], [[0, 0, np.nan]]),
         "^directions: row 0 is not finite"),
        (lambda: part.exposed(None, None), "^points: expected shape"),
        (lambda: part.exposed([[np.inf, 0, 0]], [[1.0, 0, 0]]), "^points: row 0 is not finite"),
        (lambda: part.exposed(np.zeros((2, 3)), np.ones((3, 3))), "^normals: expected 2 rows"),
        (lambda: part.surface_distance("ab"), "^points: expected an"),
        (lambda: part.first_hits([[0, 0, 5.0]], [[0, 0, -1], [0, 0, 1]]),
         "^directions: expected 1 rows"),
        (lambda: part.resolve([[np.nan, 0, 0]]), "^points: row 0 is not finite"),
    ]
    for call, message in cases:
        with pytest.raises(InputError, match=message):
            call()
    # a single point is one row, as before
    assert part.surface_distance([0.0, 0.0, 0.0]).shape == (1,)
    assert part.exposed(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
