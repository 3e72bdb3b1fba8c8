"""Property test of the config loaders: any TOML value either loads into a valid config or raises
InputError (never a TypeError, KeyError, OverflowError, ... and never a half-valid config)."""

from __future__ import annotations

import copy
import dataclasses
import datetime as dt
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from offroadbench.config import from_dict
from offroadbench.errors import InputError

# every value a TOML document can hold
SCALARS = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.datetimes(timezones=st.none() | st.just(dt.timezone.utc)),
    st.dates(),
    st.times(),
)
NEAR = st.one_of(  # values near the valid ones, where range checks live
    st.sampled_from([0, 1, -1, 0.0, 0.5, -0.5, 1.0, 2, 2.5, 3, 3.5, 1e9, -1e9, float("nan"), float("inf"), "", "low"]),
    st.integers(min_value=-3, max_value=100),
)
TOML = st.recursive(
    st.one_of(SCALARS, NEAR),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _config_classes():
    from offroadbench.analysis.roughness import RoughnessConfig
    from offroadbench.navigation.missions import MissionConfig
    from offroadbench.navigation.rules import FailureRules
    from offroadbench.sim.config import ControllerConfig, SimConfig
    from offroadbench.terrain.craters.population import PopulationConfig
    from offroadbench.terrain.craters.stamp import StampOptions
    from offroadbench.terrain.fractal.fbm import FBMConfig
    from offroadbench.terrain.fractal.wm import WMConfig

    return [RoughnessConfig, MissionConfig, FailureRules, ControllerConfig, SimConfig, PopulationConfig,
            StampOptions, FBMConfig, WMConfig]


CLASSES = _config_classes()
SMOKE = next(p for p in (Path(__file__).parents[1] / "experiments" / "smoke.toml",
                         *Path(__file__).parents[1].glob("offroadbench/**/smoke.toml")) if p.is_file())


def _assert_loads_or_input_error(load, data):
    try:
        cfg = load(data)
    except InputError as exc:
        assert str(exc).strip(), "an InputError must say what is wrong"
        return None
    return cfg


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@SETTINGS
@given(data=st.data())
def test_flat_configs_load_or_raise_input_error(cls, data):
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    keys = data.draw(st.lists(st.sampled_from(names) | st.text(max_size=6), max_size=4, unique=True))
    table = {k: data.draw(TOML) for k in keys}
    cfg = _assert_loads_or_input_error(lambda d: from_dict(cls, d), table)
    if cfg is not None:  # a config that loaded is valid: rebuilding it from its own fields passes validation
        assert isinstance(cfg, cls)
        dataclasses.replace(cfg)


@SETTINGS
@given(whole=TOML)
def test_any_toml_value_as_a_whole_table(whole):
    for cls in CLASSES:
        _assert_loads_or_input_error(lambda d, cls=cls: from_dict(cls, d), whole)
def _leaves(d, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, (*prefix, k))
        yield (*prefix, k)


def _mutate(base: dict, data) -> dict:
    out = copy.deepcopy(base)
    paths = list(_leaves(out))
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        node = out
        for p in path[:-1]:
            node = node.get(p) if isinstance(node, dict) else None
            if not isinstance(node, dict):
                break
        else:
            if data.draw(st.booleans()):
                node[path[-1]] = data.draw(TOML)
            else:
                node.pop(path[-1], None)
    return out


@SETTINGS
@given(data=st.data())
def test_recipes_load_or_raise_input_error(data):
    from offroadbench.terrain.recipe import load_recipe, recipe_from_dict

    base = dict(load_recipe(data.draw(st.sampled_from(["paper-d2.45", "lunar-mare"]))).data)
    _assert_loads_or_input_error(recipe_from_dict, _mutate(base, data))


@SETTINGS
@given(data=st.data())
def test_studies_load_or_raise_input_error(data):
    from offroadbench.config import load_toml
    from offroadbench.study.spec.config import plan_cells, study_from_dict

    base = load_toml(SMOKE)

    def load(d):
        study = study_from_dict(d)
        return study, plan_cells(study)

    _assert_loads_or_input_error(load, _mutate(base, data))
