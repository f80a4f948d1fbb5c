"""Offline grasp databases: plan many meshes, store the grasps in SQLite, query and export them.

See :mod:`synth.database.schema` for the file format, :func:`build_database` for building and
:class:`GraspDatabase` for reading.
"""

from __future__ import annotations

from synth.database.build import BuildReport, build_database, collect_mesh_files
from synth.database.export import export_database
from synth.database.schema import SCHEMA_VERSION, GraspRecord, MeshRecord
from synth.database.store import DatabaseInfo, GraspDatabase
from synth.database.worker import plan_one

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
