"""Every public name exists and the package's modules declare what they export."""

import importlib

import pytest

import synth

MODULES = ["synth", "synth.scores", "synth.grasps", "synth.errors", "synth.tolerances",
           "synth.part", "synth.contacts", "synth.fingers", "synth.plan", "synth.database",
           "synth.isolate", "synth.native", "synth.sim", "synth.formats", "synth.formats.poses",
           "synth.formats.acronym", "synth.formats.graspgen", "synth.formats.isaac",
           "synth.formats.arrays", "synth.formats.objects", "synth.plan.gripper_rank",
           "synth.database.export_objects"]


@pytest.mark.parametrize("name", MODULES)
def test_all_names_exist(name):
    mod = importlib.import_module(name)
    for item in mod.__all__:
        assert hasattr(mod, item), f"{name}.__all__ lists {item!r}, which does not exist"


def test_error_tree():
    assert issubclass(synth.MeshError, synth.InputError)
    assert issubclass(synth.InputError, ValueError)
    assert issubclass(synth.SolverError, synth.SynthError)
