"""Mesh paths stored in result files: one rule for every file synth writes and reads.

A grasp file (``synth plan``'s JSON, point fingers or gripper, ``synth rank --out``) names
the mesh it was made from in ``mesh.path``. The path is stored **relative to the folder of the
file that stores it** (so a folder of plans and meshes can be moved or copied as a whole), or
absolute when it cannot be made relative (another drive), and when the document is not written
to a file (printed). It is resolved the same way, relative to the storing file's folder,
whatever the current folder of the command that reads it: :func:`resolve_mesh_path` is the
one place that does so.

Symbolic links are followed before the relative path is made, so a path stored in a file
reached through a linked folder still leads to the mesh.

Examples
--------
>>> stored_mesh_path("/data/meshes/cube.stl", "/data/plans/cube.json")
'../meshes/cube.stl'
>>> str(resolve_mesh_path("../meshes/cube.stl", "/data/plans/cube.json"))
'/data/meshes/cube.stl'
"""

from __future__ import annotations

import os
from pathlib import Path, PurePath

from synth.errors import InputError, shown

__all__ = ["stored_mesh_path", "resolve_mesh_path"]


def stored_mesh_path(mesh: str | os.PathLike[str],
                     document: str | os.PathLike[str] | None) -> str:
    """The ``mesh.path`` to store for ``mesh`` in a file written at ``document``.

    Parameters
    ----------
    mesh : path
        The mesh file, absolute or relative to the current folder.
    document : path or None
        The file that will store the path; None when the document is not written to a file
        (the path is then absolute).

    Returns
    -------
    str
        Relative to ``document``'s folder, with ``/`` separators; absolute when ``document``
        is None or on another drive.
    """
    target = os.path.realpath(mesh)
    if document is None:
        return target
    folder = os.path.realpath(os.path.dirname(os.path.abspath(document)))
    try:
        rel = os.path.relpath(target, folder)
    except ValueError:  # another drive (Windows): no relative path exists
        return target
    return PurePath(rel).as_posix()


def resolve_mesh_path(stored: object, document: str | os.PathLike[str] | None) -> Path:
    """The mesh file a stored ``mesh.path`` names, read from the file ``document``.

    Parameters
    ----------
    stored : object
        The ``mesh.path`` value as read from the document (a non-empty string).
    document : path or None
        The file the value was read from; None for a document that was never a file (a
        relative path is then relative to the current folder).

    Returns
    -------
    pathlib.Path
        Absolute, symbolic links followed. Whether it exists is the caller's to check (and
        to say, naming ``document``'s field ``mesh.path``).

    Raises
    ------
    InputError
        If ``stored`` is not a non-empty string, naming ``document`` and the field.
    """
    if not isinstance(stored, str) or not stored:
        where = f"{document}: " if document is not None else ""
        raise InputError(f"{where}field mesh.path: expected the mesh file's path, got "
                         f"{shown(stored)}")
    path = Path(stored)
    if not path.is_absolute() and document is not None:
        path = Path(os.path.abspath(document)).parent / path
    return Path(os.path.realpath(path))
