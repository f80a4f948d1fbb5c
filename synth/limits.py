"""The documented limits of synth's inputs, in one place for every layer.

They bound what one call may ask for, so that a typing slip (``--evals 1e12``,
``--contacts 1000``, a mesh in the wrong unit) is refused at once instead of exhausting memory,
running for hours or handing the linear programs numbers they cannot solve meaningfully. The
command line states them in ``--help``; :class:`synth.PlanParams`, :func:`synth.load_part` and
the candidate readers check them.
"""

from __future__ import annotations

__all__ = ["SURFACES", "DEFAULT_SURFACE", "MAX_COORDINATE", "MAX_FACES", "MAX_LENGTH",
           "MAX_FINGERS", "AUTO_MAX_FINGERS", "MAX_CONTACTS", "MIN_EDGES", "MAX_EDGES", "MIN_EVALS",
           "MAX_EVALS", "MAX_MU", "MAX_TOP", "MAX_SEED"]

#: Largest magnitude of a vertex or contact coordinate, in the file's units. Beyond it the
#: squared lengths and moments the scores are built from overflow or swamp the LPs'
#: tolerances, so a mesh there (a unit slip, a corrupt file) is refused rather than planned on
#: meaningless numbers.
MAX_COORDINATE = 1e15
#: Largest magnitude of a length or height in the mesh's units (finger sizes, the table).
MAX_LENGTH = MAX_COORDINATE
#: Most triangles a part may have. Loading is the costly step on large meshes (measured on a
#: 1.3M-face sphere: 28 s to load and 3.1 GB peak; on a 720k-face bracket 14 s and 1.9 GB), so
#: a mesh above this would need several times that and is refused with advice to decimate.
MAX_FACES = 2_000_000
#: Most fingers a grasp may have.
MAX_FINGERS = 12
#: Most fingers ``fingers="auto"`` tries: seven single contacts hold any part that the
#: contact planner can hold, so more fingers only help when tips cannot be placed apart.
AUTO_MAX_FINGERS = 7
#: Most point contacts per grasp.
MAX_CONTACTS = 64
#: Fewest and most edges of each linearised friction cone.
MIN_EDGES, MAX_EDGES = 3, 64
#: Smallest and largest budget of grasp evaluations.
MIN_EVALS, MAX_EVALS = 100, 10_000_000
#: Largest Coulomb friction coefficient (mu = 100 already makes the cone a half-space to
#: within the LPs' accuracy; larger values only make the LPs ill-conditioned).
MAX_MU = 100.0
#: Most grasps one plan returns.
MAX_TOP = 1000
#: Largest random seed (seeds are 0 to 2**63 - 1, so they fit every integer column).
MAX_SEED = 2**63 - 1

#: The surface models a grasp can be scored with, default first (see
#: :mod:`synth.scores.surface`): which normals it must hold with.
SURFACES: tuple[str, ...] = ("both", "mesh", "smooth")
DEFAULT_SURFACE: str = SURFACES[0]
