"""Contacts on a part: the result type, sampling and rays."""

from __future__ import annotations

from synth.contacts.contacts import FEATURE_KINDS, Contacts
from synth.contacts.rays import contacts_from_rays
from synth.contacts.sample import SAMPLE_METHODS, sample_contacts

__all__ = ["FEATURE_KINDS", "Contacts", "contacts_from_rays", "sample_contacts", "SAMPLE_METHODS"]
