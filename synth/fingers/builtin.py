"""The grippers synth ships (``--gripper franka``): their names and description files.

Kept apart from the gripper model (:mod:`synth.fingers.gripper`, which loads numpy) so that
the command line can list them in ``--help`` without loading it.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["BUILTIN_GRIPPERS", "GRIPPER_FOLDER"]

#: The folder of the built-in descriptions and the meshes they name.
GRIPPER_FOLDER = Path(__file__).with_name("grippers")
#: Built-in grippers by name (``synth plan --gripper NAME``), and their description files.
BUILTIN_GRIPPERS: dict[str, str] = {
    "franka": "franka.json",
    "robotiq_2f85": "robotiq_2f85.json",
    "robotiq_2f140": "robotiq_2f140.json",
}
