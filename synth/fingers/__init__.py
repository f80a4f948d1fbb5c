"""Fingers and collisions: can every reported grasp physically be made?

A finger is a spherical tip on a capsule body (:class:`Fingers`); :func:`check_fingers`
checks a batch of grasps of one part against the part (FCL), each other and a support plane,
and :class:`FingerPlacement` is the finger geometry reported with an accepted grasp.
"""

from __future__ import annotations

from synth.fingers.collide import (
    FingerCheck,
    FingerChecker,
    check_fingers,
    checker_for,
    finger_placement,
    tip_sinks,
)
from synth.fingers.model import FingerPlacement, Fingers, default_fingers, tip_centers

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
