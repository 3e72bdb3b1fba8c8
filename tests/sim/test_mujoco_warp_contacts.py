"""The Husky on a height field, MuJoCo Warp against MuJoCo, at two states where MuJoCo Warp 4.0's
height-field collision gives a contact that is not on the terrain (docs/mujoco-warp.md, 'Not done'
item 5: the launches of engines-warp cell 3, terrain 1, mission 7 and cell 5, terrain 3, mission 6).

The state is that trial's at its launch step (the chassis' pose, float32, at rest), on a small map
that keeps the one 5 cm cell the box's front edge rests on (the trial's four heights, in metres)
and the trial's height-field size (3.84 m relief and base), shifted to the map's origin. MuJoCo's own
collision gives the box 7 contacts there, the deepest 7.1 mm, every normal level or up; MuJoCo
Warp's gives two more of 0.236 m with normal (0, 0, -1), which, left in, turn the chassis at
-7 rad/s within one MuJoCo step. The batch takes such contacts out of the solver
(offroadbench.sim.engines.mujoco_warp.kernels.drop_false_contacts), so one trial step from rest
moves the chassis as two MuJoCo steps do.

The second state is the other trial's at its launch step, on the 9 x 9 samples around its rear left
wheel (float32 as stored, over the trial's 3.84 m envelope: a second terrain of the batch holds the
envelope's lowest and highest heights). MuJoCo gives no contact there; MuJoCo Warp gives that wheel
one of 0.239 m with normal (0, 0, 1) whose witness point on the terrain lies 0.29 m above it.
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


# engines-warp cell 5 terrain 3 at MuJoCo step 755 of mission 6: the height field's samples (its
# data, heights over 3.84 m) around the rear left wheel (columns 529-537, rows 370-378) and the qpos
WHEEL_DATA = [[0.32063782, 0.33951324, 0.3283131, 0.28072023, 0.26286718, 0.25658044, 0.24054322, 0.22462806, 0.2206302],
              [0.3155871, 0.3212024, 0.31958497, 0.2814374, 0.24669261, 0.23935302, 0.23215076, 0.21402304, 0.21547265],
              [0.2870222, 0.28752574, 0.27661556, 0.25345236, 0.2338445, 0.22632182, 0.22064546, 0.21097124, 0.21364157],
              [0.28229192, 0.2635691, 0.25096512, 0.23964293, 0.22795452, 0.22806135, 0.21945526, 0.21138322, 0.21211566],
              [0.2633402, 0.25270465, 0.23642328, 0.22954147, 0.2224155, 0.22269017, 0.21654078, 0.21004044, 0.21077287],
              [0.25389487, 0.23515679, 0.22873273, 0.22238499, 0.21890593, 0.21858549, 0.2206302, 0.21318379, 0.21167316],
              [0.23736934, 0.22188143, 0.22305638, 0.22346838, 0.21968414, 0.22180514, 0.22061494, 0.21495384, 0.21322957],
              [0.22757305, 0.22340734, 0.21872282, 0.2157168, 0.21509117, 0.21426718, 0.21481651, 0.2153811, 0.21440452],
              [0.21768521, 0.21532005, 0.2142977, 0.21248189, 0.21420614, 0.21544214, 0.21477073, 0.21275654, 0.21339743]]
WHEEL_QPOS = (26.585558, 19.085665, 1.0918164, 0.2635789, 0.04049254, 0.1297044, 0.9550201, 29.108107, 26.162518,
              29.099527, 25.436062)


def _one_step_against_mujoco(model, qpos):
    """(the batch's chassis velocities after one trial step from rest at ``qpos``, MuJoCo's after
    as many MuJoCo steps, the batch)."""
    from offroadbench.sim.engines.mujoco_warp.batch import WarpBatch

    batch = WarpBatch(model, [0])
    batch.reset(0, qpos, 0)
    batch.advance(1)
    m = model.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    for _ in range(batch.substeps):
        mujoco.mj_step(m, d)
    return batch.host.qvel[0, :6], d.qvel[:6].copy(), batch


UPSTREAM = "MuJoCo Warp gave no false contact at this state: fixed upstream? (docs/mujoco-warp.md, item 5)"


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
    model, qpos = case
    warp_v, mj_v, batch = _one_step_against_mujoco(model, qpos)
    # measured: MuJoCo Warp (0.119, -0.062, -0.116) m/s, (-0.232, -0.356, -0.057) rad/s; MuJoCo
    # (0.121, -0.055, -0.115), (-0.191, -0.365, -0.065); with the downward contacts left in, the
    # chassis turns at about -7 rad/s and drops at 1.5 m/s after one MuJoCo step
    np.testing.assert_allclose(warp_v[:3], mj_v[:3], atol=0.03)
    np.testing.assert_allclose(warp_v[3:6], mj_v[3:6], atol=0.15)
    assert batch.host.dropped[0] > 0, UPSTREAM


def test_a_wheel_with_no_contact_on_mujoco_gets_none_on_the_batch():
    from offroadbench.sim.engines.mujoco_warp.model import BatchModel

    z = np.asarray(WHEEL_DATA, dtype=np.float32).astype(np.float64) * 3.84
    envelope = np.full_like(z, 1.0)
    envelope[0, 0], envelope[-1, -1] = 0.0, 3.84
    hms = [Heightmap(z=z, cell_size_m=CELL_M), Heightmap(z=envelope, cell_size_m=CELL_M)]
    model = BatchModel(hms, "husky", SimConfig(engine="mujoco_warp"))
    qpos = np.array(WHEEL_QPOS, dtype=np.float32).astype(np.float64)
    qpos[0] -= (533 - 4) * CELL_M
    qpos[1] -= (374 - 4) * CELL_M
    d = mujoco.MjData(model.model)
    d.qpos[:] = qpos
    mujoco.mj_forward(model.model, d)
    assert d.ncon == 0
    warp_v, mj_v, batch = _one_step_against_mujoco(model, qpos)
    # measured: both (0.009, 0.015, -0.159) m/s, (0.080, 0.050, 0.061) rad/s, a free fall
    np.testing.assert_allclose(warp_v, mj_v, atol=0.01)
    assert batch.host.dropped[0] > 0, UPSTREAM


def test_the_dropped_count_is_each_worlds_own_and_starts_again_at_its_spawn(case):
    """Two worlds of one batch at the false-contact state: each counts its own dropped contacts
    (WorldView.dropped_contacts, what a trial's row records as ``dropped_contacts``); resetting one
    world (a new trial's spawn) sets its count to 0 and leaves the other's running."""
    from offroadbench.sim.engines.mujoco_warp.batch import WarpBatch
    from offroadbench.sim.engines.mujoco_warp.world import WorldView

    model, qpos = case
    batch = WarpBatch(model, [0, 0])
    views = [WorldView(batch, w, 0, lambda view: None) for w in (0, 1)]
    for w in (0, 1):
        batch.reset(w, qpos, 0)
    batch.advance(1)
    first = [v.dropped_contacts() for v in views]
    assert first[0] == first[1] > 0, UPSTREAM  # the same state, the same count (per world, not shared)
    high = qpos.copy()
    high[2] += 1.0  # 1 m up: no contact at all in the next trial step
    batch.reset(0, high, 0)
    assert views[0].dropped_contacts() == 0  # from the reset on, before the batch advances
    batch.advance(1)
    assert views[0].dropped_contacts() == 0
    assert views[1].dropped_contacts() >= first[1]  # not reset: its count runs on from its own spawn
