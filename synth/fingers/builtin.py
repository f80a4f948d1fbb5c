"""The grippers synth ships (``--gripper franka``): their names and description files.

Kept apart from the gripper model (:mod:`synth.fingers.gripper`, which loads numpy) so that
the command line can list them in ``--help`` without loading it.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["BUILTIN_GRIPPERS", "GRIPPER_FOLDER", "builtin_named"]

#: The folder of the built-in descriptions and the meshes they name.
GRIPPER_FOLDER = Path(__file__).with_name("grippers")
#: Built-in grippers by name (``synth plan --gripper NAME``), and their description files.
BUILTIN_GRIPPERS: dict[str, str] = {
    "franka": "franka.json",
    "robotiq_2f85": "robotiq_2f85.json",
    "robotiq_2f140": "robotiq_2f140.json",
}

#: Other names of the built-in grippers in the ecosystem's files (ACRONYM's ``gripper/type``
#: is ``panda`` for the Franka Hand).
_ALIASES: dict[str, str] = {"panda": "franka", "franka_panda": "franka", "franka_hand": "franka",
                            "robotiq_2f_85": "robotiq_2f85", "robotiq_2f_140": "robotiq_2f140"}


def builtin_named(name: object) -> str | None:
    """The built-in gripper a pose file's gripper name means (``panda``: ``franka``), or None
    for a name that is none of them."""
    if not isinstance(name, str):
        return None
    key = name.strip().lower().replace("-", "_").replace(" ", "_")
    key = _ALIASES.get(key, key)
    return key if key in BUILTIN_GRIPPERS else None
