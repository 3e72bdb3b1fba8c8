"""The trial row's ``dropped_contacts`` (TrialResult): the engine's count of terrain contacts it took
out of its solver, read at the trial's end through the optional TrialWorld hook
``dropped_contacts()``; NaN on an engine without one (PyBullet, MuJoCo drop none by design). The
MuJoCo Warp engine's own count, per world and from each spawn, is checked at a real false contact
in tests/sim/test_mujoco_warp_contacts.py."""

import dataclasses
import importlib.util
import math

import pytest

from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.sim import SimConfig, open_world
from offroadbench.sim.trial.runner import drive_mission

MISSION = Mission.between(0, (1.0, 2.0), (4.0, 2.0))


def test_the_row_takes_the_worlds_count_and_is_nan_without_one():
    """The runner reads the hook once, at the end: a count (here a stand-in of 7 on a PyBullet
    world) becomes the row's float; no hook, or a hook that answers None, leaves NaN."""
    hm = Heightmap.flat(41, 81, 0.1)
    with open_world(hm, "husky", SimConfig(engine="pybullet")) as world:
        assert not hasattr(world, "dropped_contacts")  # drops none by design
        plain = drive_mission(world, MISSION).result
        world.dropped_contacts = lambda: 7
        counted = drive_mission(world, MISSION).result
        world.dropped_contacts = lambda: None
        answered_none = drive_mission(world, MISSION).result
    assert math.isnan(plain.dropped_contacts) and math.isnan(answered_none.dropped_contacts)
    assert counted.dropped_contacts == 7.0 and counted.as_row()["dropped_contacts"] == 7.0
    # nothing else in the row changes with the hook
    assert dataclasses.replace(counted, dropped_contacts=math.nan) == plain


@pytest.mark.skipif(importlib.util.find_spec("mujoco_warp") is None, reason="mujoco_warp not installed")
@pytest.mark.timeout(900)
def test_a_mujoco_warp_trial_records_its_count():
    """On the engine that drops false contacts the column is a count: 0 on a flat map, where none
    is false (the first run compiles Warp's CPU kernels, about 100 s; cached after)."""
    hm = Heightmap.flat(41, 81, 0.1)
    with open_world(hm, "husky", SimConfig(engine="mujoco_warp")) as world:
        row = drive_mission(world, MISSION).result
    assert row.success and row.dropped_contacts == 0.0
