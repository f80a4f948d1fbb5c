"""The planner: optimum on the cube, impossibility on surfaces of revolution, and every
returned grasp re-verified from its JSON with checks that do not share the planner's code."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth import (
    InputError,
    PlanParams,
    form_closure,
    frictional_form_closure,
    load_part,
    plan_mesh_file,
    plan_part,
    wrench_matrix,
)
from synth.part.clearance import sharp_clearance
from synth.plan.climb import CLEARANCE
from synth.plan.ranking import shown_d_star

MESHES = Path(__file__).resolve().parent.parent / "meshes"
SAMPLES = sorted(p.name for p in MESHES.glob("*.stl"))


@pytest.fixture(scope="module")
def cube_plan():
    return plan_part(load_part(MESHES / "cube.stl"), PlanParams(seed=1))


def test_cube_reaches_the_optimum(cube_plan):
    assert cube_plan.grasps, cube_plan.message
    assert cube_plan.grasps[0].d_star >= 0.49
    assert cube_plan.grasps[0].d_star <= 0.5 + 1e-9  # 0.5 is provably the best for 7 contacts
    for g in cube_plan.grasps:
        r = form_closure(wrench_matrix(g.points, g.normals))
        assert r.is_form_closure and r.rank == 6
        assert r.d_star == pytest.approx(g.d_star, abs=1e-7)


def test_grasps_are_diverse_and_ranked(cube_plan):
    g = cube_plan.grasps
    assert len(g) == 10
    shown = [shown_d_star(x.d_star) for x in g]
    assert shown == sorted(shown, reverse=True)
    L = load_part(MESHES / "cube.stl").length
    for i in range(len(g)):
        for j in range(i):
            D = np.linalg.norm(g[i].points[:, None] - g[j].points[None], axis=2)
            hd = max(D.min(0).max(), D.min(1).max())
            assert hd >= 0.05 * L - 1e-12


@pytest.mark.parametrize("name", ["sphere.stl", "cylinder.stl"])
def test_surfaces_of_revolution(name):
    part = load_part(MESHES / name)
    plan = plan_part(part, PlanParams(evals=3000))
    assert plan.grasps == ()
    assert "rotate about" in plan.message and plan.escape
    # the options to change, and their Python keywords (it read "try mu > 0 with 3 or 4 ...")
    assert "try --mu > 0 with --contacts 3 or 4" in plan.message
    # no number of contacts stops the turn: a larger budget is offered only if it is not one
    assert "if it is not, a budget above --evals 3000 may find one" in plan.message
    assert "contacts; a budget" not in plan.message
    fr = plan_part(part, PlanParams(contacts=4, mu=0.5, evals=3000, top=3))
    assert fr.grasps, fr.message
    for g in fr.grasps:
        r = frictional_form_closure(g.points, g.normals, 0.5)
        assert r.closure == "frictional form"
        assert r.d_star == pytest.approx(g.d_star, abs=1e-6)


def test_fingers_too_large_for_the_part_are_named():
    """A cube with fingertips of radius 10: every candidate puts two tips on top of each
    other; the message says so, not that the part may be a surface of revolution."""
    part = load_part(MESHES / "cube.stl")
    plan = plan_part(part, PlanParams(evals=100, finger_radius=10.0))
    assert plan.grasps == ()
    assert "fingers are too large for this part" in plan.message
    assert "two fingertips of radius 10 would overlap" in plan.message
    assert "try a smaller --finger-radius" in plan.message
    assert "rotate" not in plan.message and "revolution" not in plan.message


def test_planned_contacts_keep_clear_of_sharp_edges(tmp_path):
    """On an irregular part in float32 millimetres a million of them off the origin (feature
    tolerance 2.4e-4 of its size), a search without the clearance puts 3 of 84 contacts of
    seeds 0-3 within two tolerances of a sharp edge; with it, none."""
    from tests.test_part_scale import _shape

    mesh = _shape()
    mesh.apply_scale(1000.0)
    mesh.apply_translation(np.array([1.0, -0.6, 0.3]) * 1e6)
    path = tmp_path / "part.stl"
    mesh.export(path)
    part = load_part(path, units="mm")
    radius = CLEARANCE * part.feature_tolerance
    for seed in range(4):
        plan = plan_part(part, PlanParams(seed=seed, top=3))
        assert plan.grasps
        for g in plan.grasps:
            assert np.isinf(sharp_clearance(part, g.points, radius)).all(), seed


def test_surface_models_on_a_tessellated_cylinder():
    """The 64-sided cylinder: its facets alone give closure (``mesh``; every grasp is form
    closure by scipy's LP with the file's own facet normals, read by trimesh), the surface it
    approximates never does (the same grasps with the smooth normals are rank deficient), so
    the default (``both``) finds none, as ``smooth`` does not."""
    from tests.independent_check import lp_d_star

    part = load_part(MESHES / "cylinder.stl")
    mesh = trimesh.load(MESHES / "cylinder.stl")
    plan = plan_part(part, PlanParams(evals=3000, top=3, surface="mesh"))
    assert plan.grasps, plan.message
    for g in plan.grasps:
        _, _, faces = trimesh.proximity.closest_point(mesh, g.points)
        # each facet's normal from its corners, in double precision (the STL's stored normals
        # are rounded to float32, and this grasp's d* moves 45 times as much as its normals)
        tri = np.asarray(mesh.triangles, float)[faces]
        own = -np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        own /= np.linalg.norm(own, axis=1, keepdims=True)
        d, rank = lp_d_star(g.points, own)
        assert rank == 6 and d == pytest.approx(g.d_star, abs=1e-6)
        # the same LP solved in the search's batch and again for the report: equal to the
        # last bits, which depend on how the batch was split (synth.plan.batch)
        assert g.d_star_mesh == pytest.approx(g.d_star, abs=1e-12)
        # with the smooth normals the same contacts have lost rank (the smallest singular value
        # of their wrench matrix is about 1e-8 of the largest), so they are not closure, and
        # the LP's d* of so ill-posed a matrix depends on the solver's tolerances (0.67 from
        # scipy's LP of this matrix for one grasp, 0 from the same LP with its rows scaled
        # as the planner's scorer scales them): the rank is what is checked
        _, rank_s = lp_d_star(g.points, g.smooth_normals)
        assert rank_s < 6
    for surface in ("both", "smooth"):
        none = plan_part(part, PlanParams(evals=3000, surface=surface))
        assert none.grasps == () and "rotate about" in none.message


@pytest.mark.parametrize("name", SAMPLES)
def test_every_grasp_verifies_from_json(name):
    doc = plan_mesh_file(MESHES / name, {"evals": 10_000, "top": 5, "seed": 3})
    part = load_part(MESHES / name)
    L = part.length
    assert doc["format"] == "synth.grasps" and doc["version"] == 1
    assert doc["mesh"]["sha256"] == part.sha256
    if name in ("sphere.stl", "cylinder.stl", "torus.stl"):
        assert doc["grasps"] == []
        return
    assert doc["grasps"], doc["message"]
    for g in doc["grasps"]:
        P, N = np.array(g["points"]), np.array(g["normals"])
        # on the surface (trimesh's own closest-point query)
        _, dist, _ = trimesh.proximity.closest_point(part.mesh, P)
        assert dist.max() <= 1e-6 * L
        # unit normals that agree with the part model and point inwards
        assert np.allclose(np.linalg.norm(N, axis=1), 1.0)
        assert np.allclose(part.resolve(P).normals, N, atol=1e-6)
        # (a step small enough to stay on the contact's own face: some lie within 1e-3 of
        # the part's size of an acute edge)
        assert part.mesh.contains(P + 1e-6 * L * N).all()
        # d* recomputed from the file alone
        r = form_closure(wrench_matrix(P, N))
        assert r.is_form_closure
        assert r.d_star == pytest.approx(g["d_star"], abs=1e-7)
        # fingertips outside the part, touching it (trimesh signed distance: > 0 inside)
        f = g["fingers"]
        tips, rad = np.array(f["tip_centers"]), f["tip_radius"]
        sd = trimesh.proximity.signed_distance(part.mesh, tips)
        assert np.all(-sd >= rad * (1 - 2e-3))
        assert np.allclose(np.linalg.norm(tips - (P - rad * N), axis=1), 0, atol=1e-9)
        assert np.allclose(np.linalg.norm(f["approach"], axis=1), 1.0)
        assert g["conditioning"] >= 1e-3 and g["epsilon"] >= 0


def test_same_seed_same_grasps():
    part = load_part(MESHES / "prism.stl")
    a = plan_part(part, PlanParams(evals=2000, seed=5))
    b = plan_part(part, PlanParams(evals=2000, seed=5))
    assert [g.d_star for g in a.grasps] == [g.d_star for g in b.grasps]
    assert all(np.array_equal(x.points, y.points)
               for x, y in zip(a.grasps, b.grasps, strict=True))


@pytest.mark.parametrize("mu,contacts", [(0.0, 7), (0.5, 4)])
def test_the_machines_speed_never_changes_the_grasps(monkeypatch, mu, contacts):
    """Nothing but the clock's deadline may read the clock: a machine 1000x slower (a clock
    running 1000x fast, the deadline still far) gives bit-identical grasps."""
    part = load_part(MESHES / "bracket.stl")
    prm = PlanParams(evals=3000, seed=2, mu=mu, contacts=contacts, time=1e7)
    a = plan_part(part, prm)
    real = time.perf_counter
    monkeypatch.setattr(time, "perf_counter", lambda: 1000.0 * real())
    b = plan_part(part, prm)
    assert a.grasps and not b.stopped_by_time
    assert [g.d_star for g in a.grasps] == [g.d_star for g in b.grasps]
    assert all(np.array_equal(x.points, y.points)
               for x, y in zip(a.grasps, b.grasps, strict=True))


def test_a_default_plan_is_the_same_while_other_processes_keep_the_cores_busy():
    """The default plan (its budget, its 10 s cap) of a corpus part gives the same grasps on a
    quiet machine and with every core kept busy by other processes: it finishes its budget long
    before the cap, and nothing else in it reads the clock or the machine's load."""
    import os
    import subprocess
    import sys

    part = load_part(MESHES / "corpus" / "robosuite_bread.stl", units="m")
    quiet = plan_part(part, PlanParams(seed=3))
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
            for _ in range((os.cpu_count() or 2) + 1)]
    try:
        loaded = plan_part(part, PlanParams(seed=3))
    finally:
        for b in busy:
            b.kill()
            b.wait()
    assert quiet.grasps and not quiet.stopped_by_time and not loaded.stopped_by_time
    assert loaded.evaluations == quiet.evaluations
    assert [g.d_star for g in loaded.grasps] == [g.d_star for g in quiet.grasps]
    assert all(np.array_equal(x.points, y.points)
               for x, y in zip(quiet.grasps, loaded.grasps, strict=True))


def test_bad_parameters():
    with pytest.raises(InputError, match="at least 7"):
        PlanParams(contacts=5)
    with pytest.raises(InputError, match="mu"):
        PlanParams(mu=-1)
    with pytest.raises(InputError, match="finger_radius"):
        PlanParams(finger_radius=0.0)
    # a grip without the part's weight would give no margin: refused rather than ignored
    with pytest.raises(InputError, match="^grip: .* needs the part's weight: give mass or "
                                         "density too$"):
        PlanParams(grip=10.0)
    assert PlanParams(grip=10.0, mass=0.2).grip == PlanParams(grip=10.0, density=1e3).grip
    # a key the planner has no parameter for is named (it was Python's TypeError)
    unknown = ("^plan_mesh_file: unknown parameter 'no_such_option'; valid: contacts, .*, "
               "units, body, sharp_angle, decimate$")
    with pytest.raises(InputError, match=unknown):
        plan_mesh_file(MESHES / "cube.stl", {"no_such_option": 1})
    with pytest.raises(InputError, match="^plan_mesh_file: params must be a dict"):
        plan_mesh_file(MESHES / "cube.stl", [("evals", 2000)])  # type: ignore[arg-type]
    given = {"evals": 2000, "units": "dm"}
    plan_mesh_file(MESHES / "cube.stl", given)
    assert given == {"evals": 2000, "units": "dm"}  # the caller's dict is left as it was
    from synth.plan.gripper import plan_gripper_file

    with pytest.raises(InputError, match="^plan_gripper_file: unknown parameter 'grip'"):
        plan_gripper_file(str(MESHES / "cube.stl"), {"grip": 10})


def test_support_plane_keeps_fingers_above_the_table():
    part = load_part(MESHES / "cube.stl")
    on_table = plan_part(part, PlanParams(evals=2000, support_z=-0.5))
    assert on_table.grasps == ()  # the bottom face is unreachable: nothing pushes up
    plan = plan_part(part, PlanParams(evals=3000, top=3, support_z=-3.0))
    assert plan.grasps
    for g in plan.grasps:
        f = g.fingers
        tips = np.array(f["tip_centers"])
        ends = tips + f["body_length"] * np.array(f["approach"])
        assert (tips[:, 2] - f["tip_radius"] >= -3.0 - 1e-9).all()
        assert (ends[:, 2] - f["body_radius"] >= -3.0 - 1e-9).all()


def test_rows_that_print_the_same_d_star_are_in_conditioning_order():
    """0.5000004 and 0.4999988 both print 0.50000: the reader sees a tie, so the tie is
    broken by conditioning, whatever the digits the table does not show (issue 22)."""
    from types import SimpleNamespace

    from synth.plan.ranking import rank_grasps, shown_d_star

    g = [SimpleNamespace(name=n, d_star=d, conditioning=c, epsilon=0.0) for n, d, c in [
        ("a", 0.5000004, 0.01), ("b", 0.4999988, 0.2), ("c", 0.500002, 0.05),
        ("d", 0.499994, 0.9), ("e", 0.6, 0.001)]]
    ranked = rank_grasps(g)
    assert [x.name for x in ranked] == ["e", "b", "c", "a", "d"]
    shown = [(shown_d_star(x.d_star), x.conditioning) for x in ranked]
    assert shown == sorted(shown, reverse=True)  # what the table prints is in order


def test_ranking_ties_by_conditioning_and_rank_by():
    """d* that print the same are equal for ranking; the better-conditioned grasp comes
    first, and --rank-by orders by conditioning or epsilon instead."""
    from types import SimpleNamespace

    from synth.plan.ranking import rank_grasps

    g = [SimpleNamespace(name=n, d_star=d, conditioning=c, epsilon=e) for n, d, c, e in [
        ("a", 0.5000000004, 0.01, 0.3), ("b", 0.5, 0.2, 0.1), ("c", 0.4999999998, 0.05, 0.2),
        ("d", 0.6, 0.001, 0.05), ("e", 0.45, 0.9, 0.4)]]
    assert [x.name for x in rank_grasps(g)] == ["d", "b", "c", "a", "e"]
    assert [x.name for x in rank_grasps(g, "conditioning")] == ["e", "b", "c", "a", "d"]
    assert [x.name for x in rank_grasps(g, "epsilon")] == ["e", "a", "c", "b", "d"]
    plan = plan_part(load_part(MESHES / "cube.stl"), PlanParams(top=4, rank_by="conditioning"))
    cond = [x.conditioning for x in plan.grasps]
    assert cond == sorted(cond, reverse=True)
    assert [x["rank"] for x in plan.to_json()["grasps"]] == [1, 2, 3, 4]
    with pytest.raises(InputError, match="rank_by"):
        PlanParams(rank_by="volume")


@pytest.mark.parametrize("params", [
    {"evals": 5_000_000}, {"evals": 5_000_000, "fingers": 4},
    # one 64-contact frictional LP costs thousands of 7-contact ones: chunks shrink to match
    {"evals": 2000, "contacts": 64, "mu": 0.5}], ids=["contacts", "fingers", "64-friction"])
def test_time_caps_the_search_whatever_the_budget(params):
    """A budget far beyond the time cap (the seed stage alone would take minutes and gigabytes
    if it were drawn at once) stops at the cap, says so, and still returns what it found."""
    part = load_part(MESHES / "bracket.stl")
    t0 = time.perf_counter()
    plan = plan_part(part, PlanParams(time=1.0, top=3, **params))
    elapsed = time.perf_counter() - t0
    assert plan.stopped_by_time and plan.evaluations < params["evals"]
    assert "time limit" in plan.message
    # the contract, not a speed target: the cap holds to within one bounded chunk of work
    assert elapsed < 1.0 + 5.0, elapsed


def test_a_search_well_inside_its_cap_does_not_report_a_cut():
    plan = plan_part(load_part(MESHES / "cube.stl"), PlanParams(evals=2000, time=600.0))
    assert not plan.stopped_by_time and "time limit" not in plan.message


def test_planner_never_uses_the_compiled_simplex(monkeypatch):
    """Even with SYNTH_SIMPLEX=numba and batches of thousands of LPs (11 contacts: none has a
    one-dimensional null space), the planner keeps to the numpy simplex, so its plans do not
    depend on numba and never wait for the kernel's compile."""
    from synth.scores import simplex

    def refuse():
        raise AssertionError("the planner loaded the compiled simplex")

    monkeypatch.setenv("SYNTH_SIMPLEX", "numba")
    monkeypatch.setattr(simplex, "_compiled_module", refuse)
    plan = plan_part(load_part(MESHES / "cube.stl"), PlanParams(contacts=11, evals=6000, top=1))
    assert plan.grasps and plan.grasps[0].d_star > 0


@pytest.mark.parametrize("name, mu, ties", [("bracket.stl", 0.0, 0.5), ("tee.stl", 0.0, 0.5),
                                             ("cube.stl", 0.5, 1.0)])
def test_the_first_grasps_do_not_depend_on_how_many_are_asked_for(name, mu, ties):
    """Parts of flat faces have many frictionless grasps of d* 0.5, and with friction nearly
    every grasp has d* 1; ties break by conditioning among all the grasps the search found,
    so asking for fewer grasps gives the first rows of a longer list, not others."""
    part = load_part(MESHES / name, units="dm")
    rows = {top: [(shown_d_star(g.d_star), g.conditioning, g.points.tolist())
                  for g in plan_part(part, PlanParams(top=top, mu=mu,
                                                      contacts=7 if mu == 0 else 4)).grasps]
            for top in (1, 2, 10, 30)}
    assert sum(d == ties for d, _, _ in rows[30]) >= 3  # the ties this is about
    for top in (1, 2, 10):
        assert rows[top] == rows[30][:top]


def test_a_plan_with_fewer_grasps_than_asked_says_why() -> None:
    """A plan with fewer distinct grasps than ``top`` (a wide --diversity, or a small budget
    without one): the message counts them in the singular or plural as they are and names
    only the causes that happened (the rest within --diversity of a kept one; with no
    diversity, no others found); a full plan's message says nothing of it."""
    part = load_part(MESHES / "bracket.stl", units="dm")
    few = plan_part(part, PlanParams(top=3, evals=10000, seed=0, diversity=0.5))
    assert len(few.grasps) == 1, few.message
    assert few.message.startswith("1 form-closure grasp of the 3 asked for (the other closure "
                                  "grasps found had their contacts within 50% of the part's "
                                  "size of one of these; a larger --evals may find more)")
    alone = plan_part(part, PlanParams(top=40, evals=10000, seed=0, diversity=0.0))
    assert 1 < len(alone.grasps) < 40
    assert "(the search found no other closure grasps;" in alone.message
    assert "within" not in alone.message
    full = plan_part(part, PlanParams(top=2, evals=10000, seed=0, diversity=0.0))
    assert len(full.grasps) == 2
    assert full.message.startswith("2 form-closure grasps, best d*"), full.message


def test_the_fewer_note_names_what_happened() -> None:
    """The note of a plan short of ``top``: the time limit alone when it stopped the checks;
    otherwise each cause that happened, joined by "or"; nothing when ``top`` was met."""
    from synth.plan.search import _ABOVE_FLOOR, _fewer

    prm = PlanParams(top=5, min_d_star=0.3)
    assert _fewer(5, {}, 3, False, 0, prm) == ""
    assert _fewer(2, {"x": 1}, 3, True, 4, prm) == (
        " of the 5 asked for (the time limit passed before the rest were checked)")
    note = _fewer(2, {_ABOVE_FLOOR: 2}, 0, False, 4, prm)
    assert note.startswith(" of the 5 asked for (the other closure grasps found were dropped: "
                           "2 whose fingers would need more than --max-squeeze")
    assert note.endswith(" or had d* below --min-d-star 0.3; a larger --evals may find more)")
    assert "within" not in note
