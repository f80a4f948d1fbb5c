"""Values synth derives from a mesh, kept in trimesh's own cache of it.

trimesh empties a mesh's cache whenever its vertices or faces change, so a value kept there is
never read for a mesh it was not computed from. The loader and the part ask several of the
same questions of one mesh object (its pieces, volume, convexity, edge table); each is
answered once.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import trimesh

__all__ = ["cached"]

T = TypeVar("T")


def cached(mesh: trimesh.Trimesh, key: Any, compute: Callable[[], T]) -> T:
    """``compute()``, kept in ``mesh``'s cache under ``key`` (a string or a tuple whose
    first item names the value) until the mesh changes or the key is deleted."""
    known = mesh._cache[key]  # None when not cached (or the mesh changed)
    if known is None:
        known = mesh._cache[key] = compute()
    return known
