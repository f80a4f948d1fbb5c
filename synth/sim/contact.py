"""The contact model of a simulated grasp: the one the grasp was scored with.

MuJoCo gives a contact pair the larger ``condim`` of its two geoms (and, with equal
priority, the larger friction of each kind), so the model is set on both the part's geoms
and the fingertips:

* frictionless grasps (``mu = 0``): ``condim`` 1, a normal force only;
* frictional point contacts: ``condim`` 3, Coulomb friction ``mu`` in an elliptic cone
  (``cone="elliptic"``; MuJoCo's default pyramid is not the cone synth's measures mean);
* soft fingers (a ``torsion`` coefficient, a length): ``condim`` 4, where MuJoCo bounds the
  force and the moment about the normal together,
  ``f_n^2 >= |f_t|^2 / mu^2 + tau^2 / torsion^2`` (elliptic).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from synth.errors import InputError, shown
from synth.limits import MAX_MU

__all__ = ["ContactModel"]


@dataclass(frozen=True)
class ContactModel:
    """Friction of every finger-part contact.

    Parameters
    ----------
    mu : float
        Coulomb coefficient, 0 to ``MAX_MU``; 0 is frictionless.
    torsion : float
        Torsional friction coefficient of soft fingers, a length in the simulation's metres
        (0: point contacts, no moment about the normal). Needs ``mu > 0``.

    Examples
    --------
    >>> ContactModel(0.5).condim, ContactModel(0.0).condim
    (3, 1)
    """

    mu: float = 0.0
    torsion: float = 0.0

    def __post_init__(self) -> None:
        for name, hi in (("mu", MAX_MU), ("torsion", math.inf)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or not 0 <= v <= hi:
                raise InputError(f"ContactModel.{name}: expected a finite number from 0 to "
                                 f"{hi:g}, got {shown(v)}")
        if self.torsion > 0 and self.mu == 0:
            raise InputError("ContactModel.torsion: a soft-finger contact needs mu > 0")

    @property
    def condim(self) -> int:
        """MuJoCo's contact dimension: 1 frictionless, 3 Coulomb, 4 with torsion."""
        return 1 if self.mu == 0 else (4 if self.torsion > 0 else 3)

    @property
    def friction(self) -> list[float]:
        """MuJoCo's ``friction`` triple: sliding, torsional, rolling."""
        return [float(self.mu), float(self.torsion), 0.0]
