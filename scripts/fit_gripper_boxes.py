"""Fit the collision boxes of the built-in Robotiq grippers to robosuite's collision geometry.

How ``synth/fingers/grippers/robotiq_2f85.json`` and ``robotiq_2f140.json`` were made (printed,
then copied by hand): robosuite's MJCF of each gripper is posed at its open configuration (every
joint at 0), every collision geom (meshes with their scale, boxes) is put into the frame of the
base link's mesh (z along the approach, x along the closing direction), and boxes are fitted:
the palm to the base link, and per side one box to the inner finger with its fingertip and pad
(the part that moves with the pad) and one to the outer knuckle, outer finger and inner knuckle
(the linkage, held fixed at its open pose). The pad is robosuite's pad box. The script prints every
collision geom's bounds in the base link's frame at the open pose; the boxes of the JSON files are
read off those bounds (robosuite's y, the closing direction, is synth's x).

Usage: ``python scripts/fit_gripper_boxes.py ROBOSUITE_GRIPPERS_DIR`` (the folder
``robosuite/models/assets/grippers`` of an unpacked robosuite 1.5.2 wheel).
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation


def _tf(el: ET.Element) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [float(v) for v in el.get("pos", "0 0 0").split()]
    w, x, y, z = (float(v) for v in el.get("quat", "1 0 0 0").split())
    T[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
    return T


def _geoms(root: ET.Element, folder: Path) -> dict[str, np.ndarray]:
    scale: dict[str, float] = {}
    files: dict[str, str] = {}
    for m in root.iter("mesh"):  # a name given twice (the 2F-85's base link): the first counts
        scale.setdefault(m.get("name"), float(m.get("scale", "1 1 1").split()[0]))
        files.setdefault(m.get("name"), m.get("file"))
    out: dict[str, np.ndarray] = {}

    def walk(body: ET.Element, T: np.ndarray) -> None:
        for g in body.findall("geom"):
            if not g.get("name", "").endswith("collision"):
                continue
            Tg = T @ _tf(g)
            if g.get("type") == "box":
                h = np.array([float(v) for v in g.get("size").split()])
                V = np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T * h
            else:
                m = trimesh.load(folder / files[g.get("mesh")], force="mesh")
                V = np.asarray(m.vertices) * scale[g.get("mesh")]
            out[g.get("name")] = V @ Tg[:3, :3].T + Tg[:3, 3]
        for b in body.findall("body"):
            walk(b, T @ _tf(b))

    walk(root.find("worldbody"), np.eye(4))
    return out


def main(folder: str) -> None:
    """Print the fitted boxes of both Robotiq grippers."""
    base = Path(folder)
    for xml, side in (("robotiq_gripper_85.xml", "right"), ("robotiq_gripper_140.xml", "right")):
        root = ET.parse(base / xml).getroot()
        G = _geoms(root, base)
        B = G["hand_collision"]
        # the base link's frame: its axis of symmetry is z, the knuckles lie along the closing axis
        lo, hi = B.min(0), B.max(0)
        print(xml)
        print("  base link bounds", lo.round(4), hi.round(4))
        print(f"  (z is the approach; the {side} side's pad is the +x finger's, its y our x)")
        for name in G:
            print(f"  {name:40s}", G[name].min(0).round(4), G[name].max(0).round(4))


if __name__ == "__main__":
    main(sys.argv[1])
