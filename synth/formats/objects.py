"""One object's grasps as the ecosystem's formats hold them: poses in metres, and labels.

:class:`ObjectGrasps` is what the writers of :mod:`synth.formats` take: everything in metres
(kilograms, newtons), in the frame of the mesh file scaled by ``object_scale`` -- the
convention of ACRONYM, GraspGen and isaac_grasp files.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["ObjectGrasps", "FRAME", "MEASURE_UNITS"]

#: The gripper frame every format here uses (and synth's gripper descriptions).
FRAME = ("gripper base frame to object frame: origin at the hand's base, approach +z, fingers "
         "closing along x; a pose and its half-turn about z are the same grasp")
#: Unit of each synth measure written.
MEASURE_UNITS: dict[str, str] = {
    "margin": "1 (rated grip force / least squeeze)", "least_squeeze": "N",
    "squeeze_per_weight": "1 (squeeze / weight)", "mu_min": "1", "epsilon": "1",
    "d_star": "1", "width": "m",
    "simulated": "1 (1: the label is MuJoCo's, 0: synth's analytic verdict)"}


@dataclass(frozen=True)
class ObjectGrasps:
    """One object's gripper grasps, ready to write (see the module).

    Attributes
    ----------
    name : str
        File stem to write under.
    object_file : str
        The mesh file.
    object_scale : float
        Metres per mesh unit: the poses refer to the mesh scaled by this.
    mass : float or None
        kg.
    mass_note : str
        Where the mass comes from (or why it is unknown).
    gripper : str
    poses : (n, 4, 4) float
        Gripper base frame to the scaled mesh's frame, metres.
    widths : (n,) float
        Pad distance at each grasp, metres.
    measures : dict of str to (n,) float
        synth's measures (NaN where a measure is undefined).
    label : (n,) bool
        The verdict written as the tools' success label.
    label_meaning : str
        What ``label`` really holds.
    written_by : str
        ``synth X.Y.Z``.
    """

    name: str
    object_file: str
    object_scale: float
    mass: float | None
    mass_note: str
    gripper: str
    poses: NDArray[np.float64] = field(repr=False)
    widths: NDArray[np.float64] = field(repr=False)
    measures: dict[str, NDArray[np.float64]] = field(repr=False)
    label: NDArray[np.bool_] = field(repr=False)
    label_meaning: str = ""
    written_by: str = ""

    @property
    def frame(self) -> str:
        """The frame of the poses, one line."""
        return FRAME

    @property
    def measure_units(self) -> dict[str, str]:
        """Unit of each measure."""
        return {k: MEASURE_UNITS.get(k, "1") for k in self.measures}
