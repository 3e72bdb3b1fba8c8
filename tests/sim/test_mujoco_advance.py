"""Two speed-ups of the MuJoCo world that keep every bit: ``advance(n)``, n trial steps in one compiled
call (the trial loop's steps between two control ticks, offroadbench.sim.trial.runner.TrialLoop.
step_to_next_control), the same as ``step()`` n times, and the same trials whether the loop uses it or
not; and MuJoCo's idle stages switched off (MjcfBuilder.idle_stages), the same steps as with them on."""

from __future__ import annotations

import numpy as np
import pytest

from offroadbench.sim import SimConfig, drive_missions, open_world
from offroadbench.terrain.recipe import load_terrain

pytest.importorskip("mujoco")
MUJOCO = SimConfig(engine="mujoco")


def _state(world) -> bytes:
    d = world.data
    tc, f, ist = world._fast
    return d.qpos.tobytes() + d.qvel.tobytes() + d.qacc_warmstart.tobytes() + f.tobytes() + ist.tobytes()


def test_advance_is_step_n_times_to_the_bit():
    hm, _ = load_terrain("paper-d2.45", 3, {"grid.rows": 161, "grid.cols": 161})
    runs = {}
    for mode in ("step", "advance"):
        with open_world(hm, "husky", MUJOCO) as world:
            assert world._steps_call is not None  # the compiled path, which advance batches
            world.spawn(4.0, 4.0, 0.3)
            world.command_wheels(6.0, 4.0)
            states = []
            for n in (1, 2, 3, 3, 5, 3, 3, 7, 3, 3) * 4:
                if mode == "step":
                    for _ in range(n):
                        world.step()
                else:
                    world.advance(n)
                states.append(_state(world))
            runs[mode] = states
    assert runs["step"] == runs["advance"]
    assert len(set(runs["step"])) == len(runs["step"])  # the vehicle moved at every check


def test_trials_are_the_same_with_and_without_advance(monkeypatch):
    from offroadbench.sim.engines.mujoco.world import MuJoCoWorld

    hm, _ = load_terrain("paper-d2.45", 3, {"grid.rows": 401, "grid.cols": 401})
    with_advance = drive_missions(hm, 1, 5, length_m=8.0, vehicle="husky", sim=MUJOCO)
    monkeypatch.setattr(MuJoCoWorld, "advance", None)  # the trial loop steps one at a time
    one_by_one = drive_missions(hm, 1, 5, length_m=8.0, vehicle="husky", sim=MUJOCO)
    assert [repr(r) for r in with_advance.results] == [repr(r) for r in one_by_one.results]  # NaN fields too
    for k, tel in with_advance.telemetry.items():
        other = one_by_one.telemetry[k]
        assert tel.keys() == other.keys()
        for name in tel:
            np.testing.assert_array_equal(tel[name], other[name])


def test_idle_stages_off_change_no_bit():
    import mujoco

    hm, _ = load_terrain("paper-d2.45", 3, {"grid.rows": 161, "grid.cols": 161})
    with open_world(hm, "husky", MUJOCO) as world:
        off = world.idle_stages()
        bits = mujoco.mjtDisableBit
        assert off == int(bits.mjDSBL_ISLAND) | int(bits.mjDSBL_SPRING) | int(bits.mjDSBL_DAMPER)  # no struts
        assert world.model.opt.disableflags & off == off
        runs = []
        for flags in (world.model.opt.disableflags, world.model.opt.disableflags & ~off):
            world.model.opt.disableflags = flags
            world.spawn(4.0, 4.0, 0.3)
            world.command_wheels(6.0, 4.0)
            states = []
            for _ in range(60):
                world.advance(3)
                states.append(_state(world))
            runs.append(states)
        assert runs[0] == runs[1]
