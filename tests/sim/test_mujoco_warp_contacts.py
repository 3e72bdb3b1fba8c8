"""The chassis box on a height field, MuJoCo Warp against MuJoCo, at a state where MuJoCo Warp 4.0's
height-field collision gives a contact that points into the ground (docs/mujoco-warp.md, 'Not done'
item 5: the launch of engines-warp cell 3, terrain 1, mission 7).

The state is that trial's at its launch step (the chassis' pose, float32, at rest), on a small map
that keeps the one 5 cm cell the box's front edge rests on (the trial's four heights, in metres)
and the trial's height-field size (3.84 m relief and base), shifted to the map's origin. MuJoCo's own
collision gives the box 7 contacts there, the deepest 7.1 mm, every normal level or up; MuJoCo
Warp's gives two more of 0.236 m with normal (0, 0, -1), which, left in, turn the chassis at
-7 rad/s within one MuJoCo step. The batch takes such contacts out of the solver
(offroadbench.sim.engines.mujoco_warp.kernels.drop_false_contacts), so one trial step from rest
moves the chassis as two MuJoCo steps do.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mujoco_warp")

import mujoco  # noqa: E402

from offroadbench.heightmap import Heightmap  # noqa: E402
from offroadbench.sim.config import SimConfig  # noqa: E402

pytestmark = pytest.mark.timeout(900)

CELL_M = 0.05
# engines-warp cell 3 terrain 1: the heights of the cell at column 583, row 585 (metres above the
# height field's lowest point), and the chassis' qpos (x, y, z, quaternion wxyz) at MuJoCo step 1865
CORNERS_M = np.array([[0.1283283680677414, 0.1109330877661705],
                      [0.13083085417747498, 0.11497672647237778]]) * 3.84
CHASSIS = (29.604232788085938, 29.017303466796875, 0.5450034141540527, 0.10088834166526794,
           -0.0004452244029380381, -0.0028764137532562017, 0.9948935508728027)


@pytest.fixture(scope="module")
def case():
    from offroadbench.sim.engines.mujoco_warp.model import BatchModel

    z = np.full((8, 7), 0.30)  # under the box's bottom (0.48 m) and the wheels (0.35 m) elsewhere
    z[0, 0], z[7, 0] = 0.0, 3.84  # the trial's relief (and so its base), out of the box's reach
    z[2:4, 4:6] = CORNERS_M  # the cell, now at column 4, row 2
    model = BatchModel([Heightmap(z=z, cell_size_m=CELL_M)], "husky", SimConfig(engine="mujoco_warp"))
    qpos = np.zeros(model.model.nq)
    qpos[:7] = CHASSIS
    qpos[0] -= (583 - 4) * CELL_M
    qpos[1] -= (585 - 2) * CELL_M
    return model, qpos


def test_mujoco_gives_the_box_shallow_contacts_whose_normals_point_level_or_up(case):
    model, qpos = case
    m = model.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    terrain = model.layout()["terrain_geom"]
    box = [c for c in d.contact[:d.ncon] if terrain in c.geom]
    assert len(box) >= 3
    assert min(c.dist for c in box) > -0.01
    assert min(c.frame[2] * (1 if c.geom[0] == terrain else -1) for c in box) > -1e-3  # level: z of -1e-5


def test_one_trial_step_from_rest_moves_the_chassis_as_mujoco_does(case):
    from offroadbench.sim.engines.mujoco_warp.batch import WarpBatch

    model, qpos = case
    batch = WarpBatch(model, [0])
    batch.reset(0, qpos, 0)
    batch.advance(1)
    warp_v = batch.host.qvel[0, :6]
    m = model.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    for _ in range(batch.substeps):
        mujoco.mj_step(m, d)
    # measured: MuJoCo Warp (0.119, -0.062, -0.116) m/s, (-0.232, -0.356, -0.057) rad/s; MuJoCo
    # (0.121, -0.055, -0.115), (-0.191, -0.365, -0.065); with the downward contacts left in, the
    # chassis turns at about -7 rad/s and drops at 1.5 m/s after one MuJoCo step
    np.testing.assert_allclose(warp_v[:3], d.qvel[:3], atol=0.03)
    np.testing.assert_allclose(warp_v[3:6], d.qvel[3:6], atol=0.15)
    assert batch.host.dropped[0] > 0, ("MuJoCo Warp gave no downward contact at this state: its height-field "
                                       "collision may be fixed upstream (docs/mujoco-warp.md, item 5)")
