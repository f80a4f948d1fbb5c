"""Benchmark: does ``synth sim`` agree with ACRONYM's labels on the poses that land?

ACRONYM (Eppner, Mousavian and Fox, 2021) labels every gripper pose of its files with the
outcome of a FleX simulation of the Franka hand (``grasps/qualities/flex/object_in_gripper``:
the hand closes, then shakes; 1 when the object stayed in the hand). Its two example files
are in ``github:NVlabs/acronym``, folder ``data/examples`` (``grasps/*.h5`` and the meshes
under ``meshes/``). They are licensed CC BY-NC 4.0: copy them under ``/tmp`` (the default
``DATA`` is ``/tmp/acronym/data/examples``) and never commit them to this repository.

For each ``grasps/*.h5`` file of ``DATA``:

1. rank all its poses with the Franka hand, as the documentation does (``synth rank MESH H5
   --gripper franka --top 0 --json``), with the file's object mass (``--mass``) and the file's
   object scale as the mesh's unit (``--units '<scale>*m'``, a unit trimesh reads: the same
   poses land as without it, and ``synth sim`` needs a length unit);
2. keep the poses that land (status ``ok``: both pads rest on the part, clear of collision);
3. draw up to ``--per-class`` of ACRONYM's successful and as many of its failed landing poses
   (a fixed seed; the draw for a smaller ``--per-class`` is the first part of a larger one);
4. write them as a jaw grasp file (``synth.gripper_grasps``: ``synth rank``'s JSON is a
   ranked pose file, which ``synth sim`` does not read, so the ranked grasps' fields are
   copied into one) and simulate them with ``synth sim`` at its defaults (the plan's mu, 0.5,
   unless ``--mu``; the part's mass is ACRONYM's), ``--chunk`` grasps per call.

Printed, per file and over both: the poses that land per ACRONYM class, the confusion table
(ACRONYM success or failure against synth held, fell or error), the agreement share (of the
grasps simulated without error), and where synth's failures happen (``failed_at``).

Usage::

    python scripts/bench_acronym_sim.py [DATA] [--per-class 60] [--seed 0] [--mu MU]
    python scripts/bench_acronym_sim.py --dump run.json        # saved after every chunk
    python scripts/bench_acronym_sim.py --resume run.json      # go on where it stopped

One jaw grasp takes 0.1 to 1 s to simulate and ranking a file of 2,000 poses 10 to 30 s (a
2-core machine shared with other jobs): the default 60 a class took 2 minutes, 400 a class 15
minutes. The results are in ``docs/grippers.md`` (ACRONYM's example grasps).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import random  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

__all__ = ["main", "read_acronym_object", "jaw_document", "confusion"]

DEFAULT_DATA = Path("/tmp/acronym/data/examples")
LABEL = "grasps/qualities/flex/object_in_gripper"
#: ACRONYM's measures of how the object moved (integrals of its speed, per pose).
MOTION = ("object_motion_during_closing_linear", "object_motion_during_closing_angular",
          "object_motion_during_shaking_linear", "object_motion_during_shaking_angular")
#: The ranked grasp's fields a jaw grasp file keeps.
FIELDS = ("pose", "tcp", "width", "contacts", "measures")
CLASSES = ("success", "failure")
OUTCOMES = ("held", "fell", "error")


def synth_command(*args: str) -> list[str]:
    """The command line running ``synth`` with this interpreter (``PYTHONPATH`` chooses the
    checkout)."""
    return [sys.executable, "-m", "synth", *args]


def read_acronym_object(path: Path) -> dict[str, Any]:
    """What this benchmark reads from an ACRONYM file besides its poses: the object and the
    labels as synth's own reader gives them (:func:`synth.formats.acronym.read_acronym`), and
    the object's friction and FleX's motion measures, which synth does not read.

    Parameters
    ----------
    path : Path
        The ``.h5`` file.

    Returns
    -------
    dict
        ``mesh`` (the ``object/file`` path, relative to the data folder), ``scale`` (metres
        per mesh unit), ``mass`` (kg), ``friction``, ``labels`` (one int per pose) and
        ``motion`` (each of :data:`MOTION`: one float per pose).
    """
    import h5py

    from synth.formats.acronym import read_acronym

    poses = read_acronym(path)
    if poses.labels is None or poses.object_file is None or poses.object_mass is None:
        raise SystemExit(f"{path}: not an ACRONYM grasp file with labels, object file and mass")
    with h5py.File(path, "r") as f:
        return {"mesh": poses.object_file, "scale": float(poses.object_scale or 1.0),
                "mass": poses.object_mass, "friction": float(f["object/friction"][()]),
                "labels": [int(x) for x in poses.labels],
                "motion": {k: [float(x) for x in f[f"grasps/qualities/flex/{k}"][()]]
                           for k in MOTION}}


def rank(mesh: Path, h5: Path, scale: float, mass: float) -> dict[str, Any]:
    """``synth rank MESH H5 --gripper franka --top 0 --json`` with the file's scale as the
    mesh's unit and its mass; the ranked pose document."""
    out = subprocess.run(synth_command("rank", str(mesh), str(h5), "--gripper", "franka",
                                       "--top", "0", "--json", "--quiet",
                                       "--units", f"{scale!r}*m", "--mass", repr(mass)),
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def draw(ranked: dict[str, Any], labels: list[int], per_class: int,
         seed: int) -> tuple[dict[str, list[int]], dict[str, int]]:
    """Up to ``per_class`` landing poses of each ACRONYM class, by pose index; and how many
    land per class.

    The order of each class is one fixed shuffle (``seed``), so a smaller ``per_class`` draws
    the first poses of a larger one.
    """
    land = sorted(c["index"] for c in ranked["candidates"] if c["status"] == "ok")
    drawn, landing = {}, {}
    for k, name in enumerate(CLASSES):
        pool = [i for i in land if labels[i] == (1 if name == "success" else 0)]
        landing[name] = len(pool)
        random.Random(seed * 2 + k).shuffle(pool)
        drawn[name] = pool[:per_class]
    return drawn, landing


def jaw_document(ranked: dict[str, Any], indices: list[int]) -> dict[str, Any]:
    """A jaw grasp file (``synth.gripper_grasps``, what ``synth sim`` reads) of the ranked
    poses ``indices``, each grasp's ``acronym_index`` naming its pose."""
    by_index = {c["index"]: c for c in ranked["candidates"]}
    m, model = ranked["mesh"], ranked["model"]
    return {"format": "synth.gripper_grasps", "version": 1,
            "mesh": {"path": m["path"], "sha256": m["sha256"], "units": m["units"],
                     "length": m["length"]},
            "params": {"gripper": ranked["gripper"]["source"], "mu": model["mu"],
                       "mass": model["mass"]},
            "gripper": ranked["gripper"], "model": model,
            "grasps": [{"acronym_index": i, **{k: by_index[i][k] for k in FIELDS}}
                       for i in indices]}


def simulate(doc: dict[str, Any], mu: float | None, work: Path) -> list[dict[str, Any]]:
    """``synth sim`` of a jaw grasp file at its defaults; each grasp's ``sim`` label."""
    src, out = work / "grasps.json", work / "labelled.json"
    src.write_text(json.dumps(doc))
    extra = [] if mu is None else ["--mu", repr(mu)]
    subprocess.run(synth_command("sim", str(src), "--out", str(out), "--quiet", *extra),
                   check=True, stdout=subprocess.DEVNULL)
    return [g["sim"] for g in json.loads(out.read_text())["grasps"]]


def outcome(label: dict[str, Any]) -> str:
    """held, fell or error."""
    return "error" if label["held"] is None else ("held" if label["held"] else "fell")


def confusion(results: list[dict[str, Any]]) -> dict[str, Counter]:
    """ACRONYM class to a count of synth's outcomes."""
    table: dict[str, Counter] = {c: Counter() for c in CLASSES}
    for r in results:
        table[r["acronym"]][outcome(r["sim"])] += 1
    return table


def report(name: str, landing: dict[str, int] | None, results: list[dict[str, Any]]) -> str:
    """The printed block of one file (or of all, ``landing`` None)."""
    t = confusion(results)
    lines = [f"## {name}"]
    if landing is not None:
        lines.append("poses that land: " + ", ".join(f"{landing[c]} ACRONYM {c}"
                                                       for c in CLASSES))
    lines.append(f"{'ACRONYM':<10} {'simulated':>9} " + " ".join(f"{o:>6}" for o in OUTCOMES))
    for c in CLASSES:
        lines.append(f"{c:<10} {sum(t[c].values()):>9} "
                     + " ".join(f"{t[c][o]:>6}" for o in OUTCOMES))
    agree = t["success"]["held"] + t["failure"]["fell"]
    valid = sum(t[c]["held"] + t[c]["fell"] for c in CLASSES)
    share = f"{agree / valid:.1%}" if valid else "-"
    lines.append(f"agreement: {agree} of {valid} simulated without error ({share})")
    for c in CLASSES:
        valid_c = t[c]["held"] + t[c]["fell"]
        hit = t[c]["held"] if c == "success" else t[c]["fell"]
        if valid_c:
            lines.append(f"  ACRONYM {c}: {hit} of {valid_c} agree ({hit / valid_c:.1%})")
    for c in CLASSES:
        where = Counter(r["sim"]["failed_at"] for r in results
                        if r["acronym"] == c and r["sim"]["held"] is not True)
        if where:
            lines.append(f"synth's failures, ACRONYM {c}: "
                         + ", ".join(f"{k} {v}" for k, v in where.most_common()))
    return "\n".join(lines)


def save(path: Path | None, state: dict[str, Any]) -> None:
    """Write the dump (atomically) when one was asked for."""
    if path is not None:
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(json.dumps(state, indent=1) + "\n")
        tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA,
                   help=f"ACRONYM's data/examples folder (default {DEFAULT_DATA})")
    p.add_argument("--per-class", type=int, default=60,
                   help="landing poses drawn per ACRONYM class and file (default 60)")
    p.add_argument("--seed", type=int, default=0, help="seed of the draw (default 0)")
    p.add_argument("--mu", type=float, default=None,
                   help="simulate with this friction coefficient (synth sim --mu; default: "
                   "the plan's, 0.5)")
    p.add_argument("--chunk", type=int, default=20,
                   help="grasps per synth sim call, the dump saved after each (default 20)")
    p.add_argument("--files", nargs="*", default=None,
                   help="only the .h5 files whose name starts with one of these")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--dump", type=Path, default=None, help="save the results to this JSON")
    g.add_argument("--resume", type=Path, default=None,
                   help="go on from this dump (the same seed and --mu), saving to it")
    args = p.parse_args(argv)
    dump = args.resume or args.dump
    settings = {"seed": args.seed, "mu": args.mu}
    state: dict[str, Any] = {"settings": settings, "files": {}}
    if args.resume is not None:
        state = json.loads(args.resume.read_text())
        if state["settings"] != settings:
            p.error(f"--resume {args.resume}: made with {state['settings']}, not {settings}")
    files = sorted((args.data / "grasps").glob("*.h5"))
    if args.files:
        files = [f for f in files if f.name.startswith(tuple(args.files))]
    if not files:
        p.error(f"{args.data}: no grasps/*.h5 (ACRONYM's data/examples)")
    all_results: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for h5 in files:
            name = h5.name.split("_")[0]
            obj = read_acronym_object(h5)
            entry = state["files"].setdefault(name, {"results": {}})
            if "landing" not in entry or entry.get("per_class", 0) < args.per_class:
                print(f"{name}: ranking {len(obj['labels'])} poses ...", file=sys.stderr)
                ranked = rank(args.data / obj["mesh"], h5, obj["scale"], obj["mass"])
                drawn, landing = draw(ranked, obj["labels"], args.per_class, args.seed)
                entry.update(landing=landing, per_class=args.per_class, mass=obj["mass"],
                             friction=obj["friction"], scale=obj["scale"],
                             counts=ranked["counts"])
                order = [i for c in CLASSES for i in drawn[c]]
                entry["todo"] = jaw_document(ranked, order)
                save(dump, state)
            doc = entry["todo"]
            drawn_n = {c: 0 for c in CLASSES}
            wanted = []
            for g in doc["grasps"]:
                c = CLASSES[0] if obj["labels"][g["acronym_index"]] else CLASSES[1]
                if drawn_n[c] < args.per_class:
                    drawn_n[c] += 1
                    wanted.append(g)
            todo = [g for g in wanted if str(g["acronym_index"]) not in entry["results"]]
            for k in range(0, len(todo), args.chunk):
                part = todo[k:k + args.chunk]
                t = time.perf_counter()
                labels = simulate({**doc, "grasps": part}, args.mu, Path(tmp))
                for g, lab in zip(part, labels, strict=True):
                    i = g["acronym_index"]
                    entry["results"][str(i)] = {
                        "acronym": CLASSES[0] if obj["labels"][i] else CLASSES[1],
                        "flex": {m: obj["motion"][m][i] for m in MOTION},
                        "measures": g["measures"], "width": g["width"],
                        "touch": [c["touch"] for c in g["contacts"]], "sim": lab}
                save(dump, state)
                done = len(todo) if k + args.chunk >= len(todo) else k + args.chunk
                print(f"{name}: {done} of {len(todo)} simulated "
                      f"({(time.perf_counter() - t) / len(part):.1f} s a grasp)",
                      file=sys.stderr)
            results = [entry["results"][str(g["acronym_index"])] for g in wanted]
            all_results += results
            print(report(f"{name} (mass {obj['mass'] * 1000:.1f} g, ACRONYM friction "
                         f"{obj['friction']:g})", entry["landing"], results) + "\n")
    mu = "the plan's 0.5" if args.mu is None else f"{args.mu:g}"
    print(report(f"all files (mu {mu}, {args.per_class} per class drawn, seed {args.seed})",
                 None, all_results))
    print(f"\n{time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
