"""Offline grasp databases: plan many meshes, store the grasps in SQLite, query and export them.

See :mod:`synth.database.schema` for the file format, :func:`build_database` for building and
:class:`GraspDatabase` for reading.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from synth.lazy import lazy_attributes

if TYPE_CHECKING:  # what the lazy names are, for type checkers
    from synth.database.build import BuildReport, build_database, collect_mesh_files
    from synth.database.export import export_database
    from synth.database.schema import SCHEMA_VERSION, GraspRecord, MeshRecord
    from synth.database.store import DatabaseInfo, GraspDatabase
    from synth.database.worker import plan_one

# Imported on first use (PEP 562), so that the command line's ``synth db ... --help``
# (:mod:`synth.database.cli`) does not load numpy, FCL and the planner.
_LAZY: dict[str, str] = {
    **dict.fromkeys(["BuildReport", "build_database", "collect_mesh_files"],
                    "synth.database.build"),
    "export_database": "synth.database.export",
    **dict.fromkeys(["SCHEMA_VERSION", "GraspRecord", "MeshRecord"], "synth.database.schema"),
    **dict.fromkeys(["DatabaseInfo", "GraspDatabase"], "synth.database.store"),
    "plan_one": "synth.database.worker",
}


__getattr__ = lazy_attributes(__name__, _LAZY)

__all__ = [
    "SCHEMA_VERSION",
    "GraspDatabase",
    "DatabaseInfo",
    "MeshRecord",
    "GraspRecord",
    "BuildReport",
    "build_database",
    "collect_mesh_files",
    "export_database",
    "plan_one",
]
