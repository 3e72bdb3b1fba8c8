"""How many contacts MuJoCo's height field gives a touching wheel: the figure the MuJoCo world's
module docstring (offroadbench.sim.engines.mujoco.world, 'Contact') and ``[sim.mujoco_warp]
nconmax`` quote, measured as they say: after every trial step of paper missions, the contacts
between the terrain's hfield and each wheel's geoms, over the wheels that have at least one."""

from __future__ import annotations

import numpy as np
import pytest

from offroadbench.sim import SimConfig, drive_missions
from offroadbench.terrain.recipe import load_terrain

mujoco = pytest.importorskip("mujoco")


def test_a_touching_wheel_has_two_to_three_contacts_a_step_not_four_or_five(monkeypatch):
    from offroadbench.sim.engines.mujoco.world import MuJoCoWorld

    per_wheel: list[int] = []
    step = MuJoCoWorld.step

    def counted(world) -> None:
        step(world)
        m, d = world.model, world.data
        terrain = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
        wheel_of_body = {int(m.jnt_bodyid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)]): i
                         for i, j in enumerate(world.spec.wheel_joints)}
        n = np.zeros(len(wheel_of_body), int)
        for g1, g2 in d.contact.geom[:d.ncon].tolist():
            if terrain in (g1, g2):
                wheel = wheel_of_body.get(int(m.geom_bodyid[g2 if g1 == terrain else g1]))
                if wheel is not None:
                    n[wheel] += 1
        per_wheel.extend(n[n > 0].tolist())

    monkeypatch.setattr(MuJoCoWorld, "step", counted)
    monkeypatch.setattr(MuJoCoWorld, "advance", None)  # the trial loop steps one at a time, each counted
    hm, _ = load_terrain("paper-d2.3", 1, {"grid.rows": 401, "grid.cols": 401})
    run = drive_missions(hm, 2, 1, length_m=10.0, vehicle="husky", sim=SimConfig(engine="mujoco"))
    assert all(r.success for r in run.results)
    c = np.array(per_wheel)
    assert c.size > 2000  # four wheels on the ground for most of two 10 m missions
    # the docstrings' figure: 2.66 a touching wheel, median 2, 6 in 15 % of the wheel-steps, on 12
    # missions of 15 m (paper-d2.3 and paper-d2.45, 601^2 cells); 2.66 here too
    assert 2.0 < c.mean() < 3.2 and np.median(c) == 2
    assert 0.05 < np.mean(c == 6) < 0.3
