"""Settings classes took one suffix, Config. Their old names (*Params, *Options) still resolve, as
the same class, with a DeprecationWarning naming the new name; other missing names still raise
AttributeError."""
from __future__ import annotations

import warnings

import pytest

import vdbmap

RENAMED = [
    (vdbmap, "ReplayOptions", "ReplayConfig"),
    (vdbmap, "LogWriterOptions", "LogWriterConfig"),
    (vdbmap.planner, "ExplorationParams", "ExplorationManagerConfig"),
    (vdbmap.planner, "AlcParams", "AlcConfig"),
    (vdbmap.planner, "PathParams", "PathConfig"),
    (vdbmap.sim, "PoseGraphSolveOptions", "PoseGraphSolveConfig"),
]


@pytest.mark.parametrize("module,old,new", RENAMED)
def test_an_old_name_is_the_renamed_class_with_a_deprecation_warning(module, old, new):
    with pytest.warns(DeprecationWarning, match=f"{module.__name__}.{old} is renamed {module.__name__}.{new}"):
        cls = getattr(module, old)
    assert cls is getattr(module, new)
    assert old not in dir(module)  # not advertised: the stubs name only the new one


def test_old_names_are_usable_as_before():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        params = vdbmap.planner.ExplorationParams()
    params.alc_enabled = True
    assert isinstance(params, vdbmap.planner.ExplorationManagerConfig)


def test_a_missing_name_still_raises_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'NoSuchParams'"):
        vdbmap.planner.NoSuchParams
    assert not hasattr(vdbmap, "NoSuchOptions")
