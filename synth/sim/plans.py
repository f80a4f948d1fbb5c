"""Simulate the grasps a planner has just found: what ``synth plan --sim`` and ``synth db
build --sim`` do with a plan's document, point-finger (``synth.grasps``) or gripper
(``synth.gripper_grasps``) alike."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from synth.errors import InputError
from synth.sim.document import check_document, check_jaw_document
from synth.sim.jaws import simulate_jaw_document
from synth.sim.settings import SimSettings
from synth.sim.simulate import labelled_document, simulate_file

__all__ = ["PLAN_FORMATS", "simulate_plan", "unsimulated"]

#: The document formats :func:`simulate_plan` reads.
PLAN_FORMATS = ("synth.grasps", "synth.gripper_grasps")


def simulate_plan(doc: dict[str, Any], mesh_path: str | os.PathLike[str],
                  settings: SimSettings | None = None, *, part: Any = None,
                  load: dict[str, Any] | None = None,
                  progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """A plan's document with every grasp simulated and labelled (``sim``).

    Parameters
    ----------
    doc : dict
        A planner's document with at least one grasp: ``synth.grasps`` (its ``mesh`` object
        gives the part's size, centre of mass and volume) or ``synth.gripper_grasps``.
    mesh_path : str or os.PathLike
        The mesh file the grasps were planned on (it overrides the document's
        ``mesh.path``).
    settings : SimSettings, optional
        The hand and the disturbances (default :class:`SimSettings`).
    part : Part, optional
        The part planned on, as the planner loaded it (None: loaded again from
        ``mesh_path`` with ``load``, or with the loader options the document records).
    load : dict, optional
        :func:`synth.load_part` keywords for that.
    progress
        As :func:`synth.sim.simulate_file` takes it.

    Returns
    -------
    dict
        A copy of ``doc`` with a ``sim`` label per grasp and the run's ``sim`` summary.

    Raises
    ------
    InputError
        The document is of another format, a field the simulation needs is missing or bad
        (the message names it), or the mesh changed since it was planned. A grasp synth
        cannot simulate (a MuJoCo load failing) gets an error label
        instead (``sim.failed_at == "error"``).

    Examples
    --------
    >>> from synth import PlanParams, load_part, plan_part  # doctest: +SKIP
    >>> doc = plan_part(load_part("cube.stl"), PlanParams(top=2)).to_json()
    >>> [g["sim"]["held"] for g in simulate_plan(doc, "cube.stl")["grasps"]]
    [True, True]
    """
    fmt = doc.get("format") if isinstance(doc, dict) else None
    if fmt not in PLAN_FORMATS:
        raise InputError(f"{mesh_path}: cannot simulate a plan document of format {fmt!r}; "
                         f"expected one of {', '.join(PLAN_FORMATS)}")
    if fmt == "synth.gripper_grasps":
        if part is None:
            from synth.part import load_part
            from synth.plan import load_options

            mesh = doc.get("mesh", {})
            part = load_part(mesh_path, **(load or load_options(
                {"units": mesh.get("units"), "body": mesh.get("body", "largest"),
                 "sharp_angle": mesh.get("sharp_angle", 30.0)})))
        return simulate_jaw_document(check_jaw_document(doc, str(mesh_path)), part, settings,
                                     progress=progress)
    file = replace(check_document(doc, str(mesh_path)), mesh_path=Path(mesh_path))
    if load is not None:
        file = replace(file, load=load)
    return labelled_document(file, simulate_file(file, settings, part=part,
                                                 progress=progress))


def unsimulated(doc: dict[str, Any], reason: str, settings: SimSettings | None = None
                ) -> dict[str, Any]:
    """A plan's document whose grasps synth could not simulate: each gets an error label
    (``held`` null, ``failed_at`` ``"error"``, the ``reason``), so that the plan and its
    grasps are kept, and the run's ``sim`` summary says why.

    Parameters
    ----------
    doc : dict
        A planner's document.
    reason : str
        What went wrong (synth's own failure, not the input's).
    settings : SimSettings, optional
        The settings the simulation was to use.

    Returns
    -------
    dict
        A copy of ``doc``.
    """
    import copy

    from synth.sim.label import error_label

    st = settings or SimSettings()
    out = copy.deepcopy(doc)
    for g in out.get("grasps", []):
        g["sim"] = error_label(reason).to_dict()
    out["sim"] = {"settings": st.to_dict(), "error": reason, "held": 0,
                  "errors": len(out.get("grasps", [])), "seconds": 0.0}
    return out
