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


def test_terrains_are_split_into_runs_of_about_equal_missions_in_order():
    from types import SimpleNamespace

    from offroadbench.study.execution.batched import split_terrains

    def members(*counts):
        return [(k, SimpleNamespace(missions=[None] * n), None) for k, n in enumerate(counts)]

    def split(counts, parts):
        return [[k for k, _, _ in chunk] for chunk in split_terrains(members(*counts), parts)]

    assert split([20] * 6, 2) == [[0, 1, 2], [3, 4, 5]]
    assert split([20] * 6, 4) == [[0], [1, 2], [3], [4, 5]]  # 6 terrains in 4 runs: 1-2-1-2
    assert split([3, 3, 3], 1) == [[0, 1, 2]]
    assert split([3, 3], 8) == [[0], [1]]  # never more runs than terrains
    assert split([1, 1, 1, 9], 2) == [[0, 1, 2], [3]]  # by missions, not by terrains
    assert sum(split([5, 2, 7, 1, 4, 4, 6], 3), []) == list(range(7))  # every terrain once, in order
