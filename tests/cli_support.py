"""Inputs shared by the command-line tests."""

from __future__ import annotations

__all__ = ["BIG", "CUBE_FC"]

#: A frictionless form-closure grasp of the unit cube centred at the origin.
CUBE_FC = {
    "name": "good",
    "points": [[.5, .1, .1], [-.5, -.1, -.1], [.1, .5, .1], [-.1, -.5, -.1],
               [.2, .2, -.5], [-.2, .2, -.5], [.2, .4, .5]],
    "normals": [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1],
                [0, 0, -1]],
}
#: An integer of 400 digits, as text.
BIG = "9" * 400
