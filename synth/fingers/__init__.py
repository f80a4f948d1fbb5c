"""Fingers and collisions: can every reported grasp physically be made?

A finger is a spherical tip on a capsule body (:class:`Fingers`); :func:`check_fingers`
checks a batch of grasps of one part against the part (FCL), each other and a support plane,
and :class:`FingerPlacement` is the finger geometry reported with an accepted grasp.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from synth.lazy import lazy_attributes

if TYPE_CHECKING:  # what the lazy names are, for type checkers
    from synth.fingers.collide import (
        FingerCheck,
        FingerChecker,
        check_fingers,
        checker_for,
        finger_placement,
        tip_sinks,
    )
    from synth.fingers.model import FingerPlacement, Fingers, default_fingers, tip_centers

# Imported on first use (PEP 562): FCL and numpy load only when a finger is checked, so that
# the light modules of this package (:mod:`synth.fingers.builtin`) cost nothing.
_LAZY: dict[str, str] = {
    **dict.fromkeys(["FingerCheck", "FingerChecker", "check_fingers", "checker_for",
                     "finger_placement", "tip_sinks"], "synth.fingers.collide"),
    **dict.fromkeys(["FingerPlacement", "Fingers", "default_fingers", "tip_centers"],
                    "synth.fingers.model"),
}


__getattr__ = lazy_attributes(__name__, _LAZY)

__all__ = [
    "Fingers",
    "FingerPlacement",
    "FingerCheck",
    "FingerChecker",
    "check_fingers",
    "checker_for",
    "default_fingers",
    "finger_placement",
    "tip_centers",
    "tip_sinks",
]
