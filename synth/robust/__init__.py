"""Robust grasps: independent contact regions with a certificate, and placement tolerances."""

from synth.robust.certificate import Certificate, Expansion, certify, expand
from synth.robust.regions import ContactRegions, certify_regions, contact_regions

__all__ = ["Certificate", "ContactRegions", "Expansion", "certify", "certify_regions",
           "contact_regions", "expand"]
