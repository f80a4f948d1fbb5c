"""Every public name exists and the package's modules declare what they export."""

import importlib

import pytest

import synth

MODULES = ["synth", "synth.scores", "synth.grasps", "synth.errors", "synth.tolerances",
           "synth.part", "synth.contacts", "synth.fingers", "synth.plan", "synth.database",
           "synth.isolate", "synth.native", "synth.sim", "synth.formats", "synth.formats.poses",
           "synth.formats.acronym", "synth.formats.graspgen", "synth.formats.isaac",
           "synth.formats.arrays", "synth.formats.objects", "synth.plan.gripper_rank",
           "synth.database.export_objects"]


@pytest.mark.parametrize("name", MODULES)
def test_all_names_exist(name):
    mod = importlib.import_module(name)
    for item in mod.__all__:
        assert hasattr(mod, item), f"{name}.__all__ lists {item!r}, which does not exist"


def test_error_tree():
    assert issubclass(synth.MeshError, synth.InputError)
    assert issubclass(synth.InputError, ValueError)
    assert issubclass(synth.SolverError, synth.SynthError)


def test_top_level_functions_name_a_wrong_argument(tmp_path):
    """Each was Python's TypeError, ValueError, IndexError, AttributeError or OverflowError,
    or (precision NaN, unit 'abc', d_star NaN, faces NaN) accepted and carried on."""
    import dataclasses

    import numpy as np
    import trimesh

    part = synth.load_part("meshes/cube.stl", units="dm")
    c = synth.sample_contacts(part, 3, seed=0)
    P = np.array([[0.5, 0.1, 0.1]] * 7)
    N = np.array([[-1.0, 0, 0]] * 7)
    box = trimesh.creation.box()
    cube = ["meshes/cube.stl"]
    out = tmp_path / "d.sqlite"
    cases = [
        (lambda: synth.Part(box, precision=float("nan")), "^Part: precision: expected"),
        (lambda: synth.Part(box, units="abc"), "^Part: units: expected a length unit"),
        (lambda: synth.load_part("meshes/cube.stl", sharp_angle=None), "^sharp_angle: expected"),
        (lambda: dataclasses.replace(c, faces=np.full(3, np.nan)), "^Contacts.faces: expected "
                                                                   "integers"),
        (lambda: c.select(np.array([0, 99])), "^Contacts.select: row indices from -3 to 2"),
        (lambda: synth.Contacts.concatenate([c, None]), "^Contacts.concatenate: item 1"),
        (lambda: synth.read_candidates(None), "^path: expected a candidate file's path"),
        (lambda: synth.contact_regions(part, P, N, d_star=float("nan")), "^d_star: expected"),
        (lambda: synth.contact_regions(part, P, N, seed=-1), "^seed: expected an integer"),
        (lambda: synth.contact_regions(part, P, N, mu=None), "^mu: expected a number"),
        (lambda: synth.certify_regions(P, N, [p[None] for p in P], "abc", 1.0),
         "^certify_regions: center: expected 3 finite numbers"),
        (lambda: synth.certify_regions(P, N, [p[None] for p in P], [0, 0, 0], 1.0, seed="x"),
         "^seed: expected an integer"),
        (lambda: synth.default_fingers(part, nosuch=1), "^default_fingers: unknown field "
                                                        "'nosuch'"),
        (lambda: synth.plan_part(part, synth.PlanParams(), progress="abc"), "^progress: "),
        (lambda: synth.build_database(5, out, {}), "^sources: expected folders"),
        (lambda: synth.build_database(cube, out, {}, workers="abc"),
         r"^--workers \(Python: workers=\)"),
        (lambda: synth.build_database(cube, out, {}, workers=float("inf")),
         r"^--workers \(Python: workers=\)"),
        (lambda: synth.build_database(cube, out, {}, timeout="abc"), "^timeout: expected"),
        (lambda: synth.build_database(cube, out, {}, planner=5), "^planner: expected"),
    ]
    for call, message in cases:
        with pytest.raises(synth.InputError, match=message):
            call()
    assert not out.exists()
    assert synth.default_fingers(part, tip_radius=None) == synth.default_fingers(part)


def test_module_functions_name_a_wrong_argument(tmp_path):
    """The second batch: each was a bare IndexError, TypeError, ZeroDivisionError or
    LinAlgError (or, for an edge given as None, the normals of all 36 edges)."""
    import numpy as np

    from synth.formats import read_gripper_poses
    from synth.formats.poses import GripperPoses
    from synth.plan.render import export_glb, render_png
    from synth.scores.wrench import numerical_rank

    part = synth.load_part("meshes/cube.stl", units="dm")
    plan = synth.plan_part(part, synth.PlanParams(evals=2000, top=2))
    db_path = tmp_path / "d.sqlite"
    with synth.GraspDatabase(db_path, "w"):
        pass
    db = synth.GraspDatabase(db_path)
    poses = GripperPoses("p.npz", "npz", np.eye(4)[None], ("0",), 1.0, "m", None, None)
    cases = [
        (lambda: part.normal_cone("edge", None), "^edge index: expected an integer from 0 to"),
        (lambda: part.normal_cone("face", 10**6), "^face index: expected an integer from 0 to 11"),
        (lambda: part.edge_kind(1.5), "^edge index"),
        (lambda: part.features.edges_of_kind("nosuch"), "^kind: expected one of"),
        (lambda: numerical_rank(5), r"^W: expected a finite \(m, n\)"),
        (lambda: numerical_rank(np.full((6, 7), np.nan)), "NaN or infinite"),
        (lambda: read_gripper_poses(None), "^path: expected a gripper pose file's path"),
        (lambda: poses.to_part(0.0, "cm"), "^part_metres: expected a positive number"),
        (lambda: poses.to_part(float("nan"), "cm"), "^part_metres"),
        (lambda: export_glb(part, plan, tmp_path / "a.glb", grasp=5), "^grasp: expected an "
                                                                      "index from 0 to 1"),
        (lambda: export_glb(None, plan, tmp_path / "a.glb"), "^part: expected a synth.Part"),
        (lambda: render_png(part, plan, None), "^path: expected a file path"),
        (lambda: render_png(part, plan, tmp_path / "a.png", panels=1.5), "^panels: expected"),
        (lambda: db.mesh(None), "^mesh: expected a mesh's id"),
        (lambda: list(db.grasps(mesh=1.5)), "^mesh: expected a mesh's id"),
        (lambda: db.id_of("nosuch.stl"), "no mesh stored with the path 'nosuch.stl'"),
        (lambda: db.rows_by_path(None), "^paths: expected a list of mesh paths"),
    ]
    for call, message in cases:
        with pytest.raises(synth.InputError, match=message):
            call()
    db.close()
    assert not (tmp_path / "a.glb").exists() and not (tmp_path / "a.png").exists()


def test_simulation_and_certificate_functions_name_a_wrong_argument():
    """The third batch: the simulator's and the region certificate's entry points (a zero
    length divided by zero, NaN made a LinAlgError, None an AttributeError, an empty region an
    IndexError, and expand's own ValueError was not an InputError)."""
    import numpy as np

    from synth.robust.certificate import certify, expand

    sim = pytest.importorskip("synth.sim")
    W = np.hstack([np.eye(6), -np.ones((6, 1))])
    D = np.zeros((7, 2, 6))
    e = expand(W, D)
    cases = [
        (lambda: expand(W[:, :3], D), r"^expand: W must be m x \(m \+ 1\)"),
        (lambda: expand(W * np.nan, D), "^expand: W and D must be finite"),
        (lambda: certify(None, [np.zeros((1, 2))] * 7), "^certify: e must come from expand"),
        (lambda: certify(e, [np.zeros((0, 2))] * 7), r"^certify: polygons\[0\]: expected"),
        (lambda: certify(e, [np.full((1, 2), np.nan)] * 7), r"^certify: polygons\[0\]"),
        (lambda: sim.predicted_escape(W[:3].T, W[:3].T, 0.0, np.zeros(3), float("nan")),
         "^length: expected a positive finite number"),
        (lambda: sim.part_shape(None), "^part: expected a synth.Part"),
        (lambda: sim.run_protocol(None), "^scene: expected a Scene"),
        (lambda: sim.simulate_file(None), "^file: expected a GraspFile"),
        (lambda: sim.check_mesh(None), "^file: expected a GraspFile"),
        (lambda: sim.check_document({}, name=None), "^name: expected the document's name"),
        (lambda: sim.check_jaw_document({}, labels=[1]), "^labels: expected a list of grasp "
                                                        "names"),
    ]
    for call, message in cases:
        with pytest.raises(synth.InputError, match=message):
            call()


def test_finger_and_export_helpers_name_a_wrong_argument():
    """The fourth batch: tip_centers (a NaN radius gave NaN centres), a finger check's
    placement, sweep_length, load_options and export_database's output."""
    import numpy as np

    from synth.database import export_database
    from synth.fingers import checker_for
    from synth.fingers.model import tip_centers
    from synth.plan import load_options

    part = synth.load_part("meshes/cube.stl", units="dm")
    P, N = np.zeros((1, 1, 3)), np.array([[[0.0, 0.0, -1.0]]])
    check = synth.check_fingers(part, P, N, synth.default_fingers(part))
    cases = [
        (lambda: tip_centers(P, N, float("nan")), "^tip_radius: expected a positive finite"),
        (lambda: tip_centers(None, N, 0.1), r"^points and normals: expected two \(B, k, 3\)"),
        (lambda: check.placement(5), "^i: expected a grasp index from 0 to 0, got 5"),
        (lambda: checker_for(part).sweep_length(None), "^fingers: expected a synth Fingers"),
        (lambda: load_options(None), "^load_options: expected a dict"),
        (lambda: load_options({"sharp_angle": "x"}), "^sharp_angle: expected degrees"),
        (lambda: export_database("grasps.sqlite", None), "^out: expected the export file's"),
    ]
    for call, message in cases:
        with pytest.raises(synth.InputError, match=message):
            call()


def test_squeeze_escape_and_sink_helpers_name_a_wrong_argument():
    """least_squeeze_batch (linprog's ValueError for a NaN mu or a zero length),
    escape_twist (an IndexError for a free column past the last) and tip_sinks."""
    import numpy as np
    import trimesh

    from synth.fingers.collide import tip_sinks
    from synth.scores.escape import escape_twist
    from synth.scores.gravity import least_squeeze_batch

    P = np.array([[[0.5, 0, 0], [-0.5, 0, 0]]])
    N = -2 * P
    assert least_squeeze_batch(P, N, 0.5, 0.0, [0, 0, 0], 1.0, [0, 0, -1])[0, 0] == 1.0
    cases = [
        (lambda: least_squeeze_batch(P, N, float("nan"), 0.0, [0, 0, 0], 1.0, [0, 0, -1]),
         "^mu: expected finite numbers >= 0"),
        (lambda: least_squeeze_batch(P, N, 0.5, 0.0, [0, 0, 0], 0.0, [0, 0, -1]), "^length"),
        (lambda: least_squeeze_batch(P, N, 0.5, 0.0, [0, 0, 0], 1.0, np.zeros(2)),
         r"^directions: expected gravity directions \(3,\) or \(n, 3\)"),
        (lambda: escape_twist(np.eye(6, 7), (99,), rank_deficient=False),
         "^free: expected column indices from 0 to 6"),
        (lambda: tip_sinks(trimesh.creation.box(), 5, 0.1), "^centers: expected finite"),
    ]
    for call, message in cases:
        with pytest.raises(synth.InputError, match=message):
            call()
