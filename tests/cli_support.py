"""Inputs shared by the command-line tests."""

from __future__ import annotations

import json
import struct
from pathlib import Path

__all__ = ["BIG", "CUBE_FC", "earlier_output"]

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


def earlier_output(path: Path, tag: str = "earlier") -> bytes:
    """Write at ``path`` a small stand-in for an earlier output of synth (which synth may
    replace), in the format its suffix names, and return its bytes: a JSON document of a
    synth format, a PNG with a ``synth.run_id`` text chunk, a GLB whose scene extras hold a
    ``synth`` entry. ``tag`` tells stand-ins apart."""
    suffix = path.suffix.lower()
    if suffix == ".png":
        data = (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13 + len(tag)) + b"tEXt"
                + b"synth.run_id\x00" + tag.encode() + b"\x00\x00\x00\x00")
    elif suffix == ".glb":
        doc = json.dumps({"asset": {"version": "2.0"},
                          "scenes": [{"extras": {"synth": {"run_id": tag}}}]}).encode()
        doc += b" " * (-len(doc) % 4)
        data = (b"glTF" + struct.pack("<II", 2, 20 + len(doc)) + struct.pack("<I", len(doc))
                + b"JSON" + doc)
    else:
        data = json.dumps({"format": "synth.grasps", "earlier": tag}).encode()
    path.write_bytes(data)
    return data
