"""Candidate grasps: contact sets read from files or built by the planner."""

from synth.grasps.candidates import Candidate, min_contacts, read_candidates

__all__ = ["Candidate", "min_contacts", "read_candidates"]
