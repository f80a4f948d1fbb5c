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
from synth.sim.document import check_document
from synth.sim.jaws import simulate_jaw_document
from synth.sim.settings import SimSettings
from synth.sim.simulate import labelled_document, simulate_file

__all__ = ["PLAN_FORMATS", "simulate_plan"]

#: The document formats :func:`simulate_plan` reads.
PLAN_FORMATS = ("synth.grasps", "synth.gripper_grasps")


def simulate_plan(doc: dict[str, Any], mesh_path: str | os.PathLike[str],
                  settings: SimSettings | None = None, *, part: Any = None,
                  load: dict[str, Any] | None = None, cache: Any = True,
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
        For a gripper document, the part planned on (its document does not carry the part's
        centre of mass and volume); None loads it from ``mesh_path`` with ``load``.
    load : dict, optional
        :func:`synth.load_part` keywords for that (the gripper planner's: ``units``).
    cache, progress
        As :func:`synth.sim.simulate_file` takes them.

    Returns
    -------
    dict
        A copy of ``doc`` with a ``sim`` label per grasp and the run's ``sim`` summary.

    Raises
    ------
    InputError
        The document is of another format, a field the simulation needs is missing or bad
        (the message names it), the mesh changed since it was planned, or MuJoCo cannot
        load it.

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

            part = load_part(mesh_path, **(load or {}))
        return simulate_jaw_document(doc, part, mesh_path, settings, cache=cache,
                                     progress=progress)
    file = replace(check_document(doc, str(mesh_path)), mesh_path=Path(mesh_path))
    return labelled_document(file, simulate_file(file, settings, cache=cache,
                                                 progress=progress))
