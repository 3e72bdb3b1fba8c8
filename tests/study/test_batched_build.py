"""The ``batched`` executor builds its terrains in forked processes
(offroadbench.study.execution.batched.build_terrains): each terrain, its class map and its missions
are the same to the bit with 1 or 3 builders, in the tasks' order; a build's error reaches the
coordinator as itself."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from offroadbench.errors import InputError
from offroadbench.study.execution.batched import build_terrains
from offroadbench.study.runner import plan_tasks
from offroadbench.study.spec.config import load_study


def _tasks():
    study, plans = load_study(Path(__file__).parents[2] / "experiments" / "smoke.toml")
    return plan_tasks(study, plans, set())[:4]


def _summary(built):
    prepared, msgs = built
    return (prepared.hm.z.tobytes(), prepared.maps.closed.tobytes(), prepared.missions,
            [(type(m).__name__, m.cell, m.terrain, m.terrain_seed) for m in msgs])


def test_terrains_built_by_several_processes_are_the_ones_built_here():
    tasks = _tasks()
    here = [_summary(b) for b in build_terrains(tasks, 1)]
    forked = [_summary(b) for b in build_terrains(tasks, 3)]
    assert here == forked
    assert [s[3][0][1:3] for s in here] == [(t.cell.index, t.terrain) for t in tasks]  # in the tasks' order
    assert len({s[0] for s in here}) == len(tasks)  # four different terrains


def test_a_build_error_in_a_worker_is_raised_in_the_coordinator():
    tasks = _tasks()
    bad = tasks[2]
    settings = {**bad.cell.settings, "missions": {**bad.cell.settings.get("missions", {}), "length_m": 40.0}}
    tasks[2] = dataclasses.replace(bad, cell=dataclasses.replace(bad.cell, settings=settings))
    with pytest.raises(InputError, match="too small for 40 m missions"):
        list(build_terrains(tasks, 2))
