"""Candidate grasps: contact sets read from files or built by the planner."""

from synth.grasps.candidates import (
    Candidate,
    CandidateGroup,
    CandidateTable,
    min_contacts,
    read_candidate_table,
    read_candidates,
)

__all__ = ["Candidate", "CandidateGroup", "CandidateTable", "min_contacts",
           "read_candidate_table", "read_candidates"]
