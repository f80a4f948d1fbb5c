"""Export a database's gripper grasps in the ecosystem's layouts: one file per object.

``synth db export DB --format acronym|graspgen|isaac --out DIR`` writes, for every mesh with
gripper grasps, ``DIR/<mesh stem>.h5`` (``.json``, ``.yaml``) through the writers of
:mod:`synth.formats`. Everything is in metres: the object scale is the metres per mesh unit,
so the tools' loaders (which scale the mesh by it, then apply the poses) put the gripper where
synth planned it. A mesh whose unit the database does not know is refused with the reason,
unless ``units`` names it.

The tools' success label (ACRONYM's ``grasps/qualities/flex/object_in_gripper``, GraspGen's
``grasps.object_in_gripper``, isaac_grasp's ``confidence``) holds, per grasp, the MuJoCo label
(``held``) when the grasp was simulated (``synth db build --sim``), otherwise synth's analytic
verdict: the grasp is frictional form closure with the pads' soft contacts, and, where the
part's mass is known, the gripper's rated force holds it against gravity in every orientation
(margin >= 1). The measure ``simulated`` (1 or 0) says which, and the files say so where they
store the label.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from synth.database.store import GraspDatabase
from synth.errors import InputError
from synth.files import atomic_path
from synth.formats import WRITERS, ObjectGrasps

__all__ = ["export_objects", "VERDICT"]

#: What the success label of an export holds.
VERDICT = ("per grasp, where the measure 'simulated' is 1 ({sims} of {n} grasps): MuJoCo's label "
           "made by {simulator} (synth db build --sim: 1 when the part stayed held; see "
           "docs/simulation.md); elsewhere synth's analytic "
           "verdict, not a simulation: 1 when the grasp is frictional form closure with the "
           "pads' soft contacts (MuJoCo condim 4, mu {mu}, torsion {torsion}) {mass}")
_MEASURES = ("margin", "least_squeeze", "squeeze_per_weight", "mu_min", "epsilon", "d_star")


def _metres(units: str, where: str) -> float:
    from synth.formats.arrays import unit_metres

    return unit_metres(units, where, "units")


def _objects(db: GraspDatabase, units: str | None) -> list[ObjectGrasps]:
    from synth import __version__
    from synth.scores.gravity import GRAVITY

    params = db.params
    out = []
    stems: dict[str, int] = {}
    for mesh in db.meshes("done"):
        grasps = list(db.gripper_grasps(mesh.id))
        if not grasps:
            continue
        unit = mesh.units or units
        if unit is None:
            raise InputError(f"{mesh.path}: its length unit is unknown (the database does not "
                             "say), and these formats hold poses in metres: give --units")
        m = _metres(unit, mesh.path if mesh.units is None else f"{db.path}: mesh {mesh.path}")
        stem = Path(mesh.name).stem
        stems[stem] = stems.get(stem, 0) + 1
        name = stem if stems[stem] == 1 else f"{stem}-{mesh.id}"
        poses = np.array([g.pose for g in grasps])
        poses[:, :3, 3] *= m
        known = [(g.least_squeeze, g.squeeze_per_weight) for g in grasps
                 if g.least_squeeze is not None and g.squeeze_per_weight is not None]
        mass = known[0][0] / (known[0][1] * GRAVITY) if known else None
        how = ("from the stored least squeeze (the build's --mass or --density)" if known else
               "unknown: the build had no --mass nor --density")
        meas = {k: np.array([np.nan if getattr(g, k) is None else getattr(g, k)
                             for g in grasps], float) for k in _MEASURES}
        # a grasp synth could not simulate (its label says why: held is null) takes the
        # analytic verdict, as one not simulated
        sims = [g.sim if g.sim is not None and g.sim.get("held") is not None else None
                for g in grasps]
        simulated = np.array([sim is not None for sim in sims])
        label = np.array([bool(sim["held"]) if sim is not None else
                          g.d_star > 0 and (g.margin is None or g.margin >= 1.0)
                          for g, sim in zip(grasps, sims, strict=True)])
        meas["simulated"] = simulated.astype(float)
        makers = sorted({str(sim.get("simulator", "synth.sim 1"))
                         for sim in sims if sim is not None})
        verdict = VERDICT.format(
            sims=int(simulated.sum()), n=len(grasps), simulator=" and ".join(makers) or "-",
            mu=params.get("mu"), torsion="default 5 mm" if params.get("torsion") is None
            else f"{params['torsion']} mesh units",
            mass="and the gripper's rated grip force holds the part's weight in every "
            "orientation (margin >= 1); 0 otherwise" if known else
            "(the part's mass is unknown, so the weight is not checked); 0 otherwise")
        out.append(ObjectGrasps(name, mesh.path, m, mass, how, grasps[0].gripper, poses,
                                np.array([g.width for g in grasps]) * m, meas, label, verdict,
                                f"synth {__version__}"))
    return out


def export_objects(database: str | os.PathLike[str], out: str | os.PathLike[str], fmt: str,
                   units: str | None = None) -> list[Path]:
    """Write every mesh's gripper grasps of ``database`` as files of format ``fmt``.

    Parameters
    ----------
    database : path
    out : path
        A folder (created if missing); each file is replaced only once complete.
    fmt : {"acronym", "graspgen", "isaac"}
    units : str, optional
        The length unit of meshes whose unit the database does not know.

    Returns
    -------
    list of Path
        The files written, in mesh order.

    Raises
    ------
    InputError
        An unknown format, a database without gripper grasps, or a mesh of unknown unit
        without ``units``.
    """
    if fmt not in WRITERS:
        raise InputError(f"--format (Python: fmt=): expected one of {', '.join(WRITERS)}, got "
                         f"{fmt!r}")
    if fmt == "acronym":
        from synth.formats.acronym import write_acronym as write
    elif fmt == "graspgen":
        from synth.formats.graspgen import write_graspgen as write
    else:
        from synth.formats.isaac import write_isaac as write
    with GraspDatabase(database) as db:
        objects = _objects(db, units)
        if not objects:
            raise InputError(f"{database}: no gripper grasps to export as {fmt} (these formats "
                             "hold gripper poses; point-finger grasps export as h5, npz or "
                             "json, which give each finger's frame)")
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: is a file; --format {fmt} writes one file per mesh into a "
                         "folder: give a folder name")
    targets = [folder / f"{obj.name}{WRITERS[fmt]}" for obj in objects]
    for path in targets:  # all checked before any is written
        if path.exists() and not (path.is_file() and _ours(path)):
            raise InputError(f"--out {folder}: {path.name} there is not a file synth exported "
                             "(synth replaces only its own outputs); give another folder or "
                             "move it")
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for obj, path in zip(objects, targets, strict=True):
        with atomic_path(path) as tmp:
            write(tmp, obj)
        paths.append(path)
    return paths


def _ours(path: Path) -> bool:
    """Whether a per-object file is one synth exported: its ``written_by`` (an HDF5
    attribute, the ``synth`` entry of a JSON or YAML document) names synth."""
    import re

    try:
        if path.suffix == ".h5":
            import h5py

            with h5py.File(path, "r") as f:
                return str(f.attrs.get("written_by", "")).startswith("synth ")
        with open(path, "rb") as fh:
            head = fh.read(1 << 20)
    except Exception:  # noqa: BLE001 - unreadable or damaged: not synth's
        return False
    return re.search(rb'(^|\s|")written_by"?\s*:\s*"?synth ', head) is not None
