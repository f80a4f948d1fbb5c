"""Parts: a mesh file becomes a cleaned mesh with features, regions and normals."""

from __future__ import annotations

from synth.part.features import EDGE_KINDS, VERTEX_KINDS, Features
from synth.part.load import SUPPORTED_FORMATS, load_part
from synth.part.model import Part
from synth.part.regions import Region

__all__ = ["EDGE_KINDS", "VERTEX_KINDS", "SUPPORTED_FORMATS", "Features", "Part", "Region",
           "load_part"]
