"""The mast sensor: occlusion (a crater floor behind its rim is unseen until the vehicle is past the
rim), unknown cells stay NaN, height noise grows with range, odometry drift moves the map and the
believed pose together, a trial's sensing replays bit for bit, and the configs are checked."""

import math

import numpy as np
import pytest

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.navigation.missions import Mission
from offroadbench.navigation.perception import PerceptionConfig
from offroadbench.navigation.planners import planner_from_table
from offroadbench.navigation.sensor import MastSensor, Oracle, make_sensing, sheet_envelope, viewshed

CELL = 0.05
CLEAN = PerceptionConfig(sensor="mast", sensor_range_m=12.0, sensor_noise_per_range=0.0, odometry_drift=0.0)


def _crater() -> Heightmap:
    """Flat ground with a crater centred at (12, 5) m: a 0.4 m rim at r = 2 m round a 1 m deep bowl."""
    y, x = np.mgrid[0:201, 0:401] * CELL
    r = np.hypot(x - 12.0, y - 5.0)
    z = 0.4 * np.exp(-(((r - 2.0) / 0.3) ** 2)) - 1.0 * np.clip(1.0 - (r / 1.8) ** 2, 0.0, None)
    return Heightmap(z, CELL)


def _cell(z: np.ndarray, x: float, y: float) -> float:
    return float(z[int(round(y / CELL)), int(round(x / CELL))])


def test_a_crater_behind_its_rim_is_unseen_from_before_the_rim_and_seen_after():
    hm = _crater()
    sensor = MastSensor(hm, CLEAN, np.random.default_rng(0), (4.0, 5.0), 0.0)
    z = sensor.z
    assert math.isnan(_cell(z, 12.0, 5.0))  # the crater floor, behind the near rim
    assert math.isnan(_cell(z, 11.0, 5.0))
    assert _cell(z, 6.0, 5.0) == pytest.approx(hm.z[100, 120], abs=0.01)  # the ground before the rim is seen
    assert _cell(z, 10.0, 5.0) == pytest.approx(hm.z[100, 200], abs=0.01)  # the near rim's crest is seen
    assert not math.isnan(_cell(z, 14.0, 5.0))  # the far rim's crest stands above the line of sight
    for x in np.arange(4.0, 10.51, 0.05):  # drive over the rim, scanning every 0.25 m
        sensor.update((x, 5.0, 0.0), 0.0)
    assert sensor.scans > 20
    assert _cell(sensor.z, 12.0, 5.0) == pytest.approx(hm.z[100, 240], abs=0.01)  # now seen, as it is
    assert _cell(sensor.z, 11.0, 5.0) == pytest.approx(hm.z[100, 220], abs=0.01)
    far = MastSensor(hm, PerceptionConfig(sensor="mast", sensor_range_m=3.0), np.random.default_rng(0), (4.0, 5.0), 0.0)
    assert math.isnan(_cell(far.z, 8.0, 5.0)) and not math.isnan(_cell(far.z, 6.0, 5.0))


def test_the_viewshed_of_a_flat_plain_is_everything_in_range_and_a_wall_hides_what_is_behind_it():
    z = np.zeros((201, 201))
    x, y, h, r = viewshed(Heightmap(z, CELL), (5.0, 5.0), 0.75, 4.0)
    assert len(x) == len(r) and r.max() <= 4.0 + 1e-9 and np.all(h == 0.0)
    n_a = math.ceil(2 * math.pi * 4.0 / CELL)
    assert len(x) == n_a * int(4.0 / CELL)  # every sample of every azimuth
    z[:, 130:132] = 2.0  # a 2 m wall at x = 6.5 m
    x, _, _, _ = viewshed(Heightmap(z, CELL), (5.0, 5.0), 0.75, 4.0)
    assert x.max() < 6.6  # nothing beyond the wall


def test_height_noise_grows_with_range():
    hm = Heightmap(np.zeros((401, 401)), CELL)
    cfg = PerceptionConfig(sensor="mast", sensor_range_m=9.0, sensor_noise_per_range=0.01, odometry_drift=0.0)
    z = MastSensor(hm, cfg, np.random.default_rng(1), (10.0, 10.0), 0.0).z
    yy, xx = np.mgrid[0:401, 0:401] * CELL
    r = np.hypot(xx - 10.0, yy - 10.0)
    near = z[(r > 1.0) & (r < 2.0)]
    far = z[(r > 7.0) & (r < 8.0)]
    # a cell averages the samples that fell in it, so compare with the ratio of ranges loosely (far
    # cells between two azimuths' samples stay unknown)
    assert np.nanstd(far) > 3.0 * near.std() > 0.0
    assert np.nanstd(far) < 0.01 * 8.0 and np.isnan(far).mean() < 0.3


def test_odometry_drift_moves_the_believed_pose_and_the_map_together():
    z = np.zeros((401, 401))
    z[200, 300] = 1.0  # a post at (15, 10) m
    hm = Heightmap(z, CELL)
    cfg = PerceptionConfig(sensor="mast", sensor_range_m=9.0, sensor_noise_per_range=0.0, odometry_drift=0.05)
    sensor = MastSensor(hm, cfg, np.random.default_rng(3), (2.0, 10.0), 0.0)
    for x in np.arange(2.0, 12.01, 0.05):
        pose = sensor.update((x, 10.0, 0.0), 0.0)
    err = np.array(pose[:2]) - [12.0, 10.0]
    assert 0.01 < np.hypot(*err) < 2.0  # it drifted, by the order of 5 % of 10 m
    assert pose[2] == pytest.approx(sensor.heading_error)
    # the post is in the map where the vehicle believes it saw it: belief + R(psi) (post - truth)
    c, s = math.cos(sensor.heading_error), math.sin(sensor.heading_error)
    qx, qy = pose[0] + c * 3.0, pose[1] + s * 3.0
    r, col = np.unravel_index(np.nanargmax(sensor.z), z.shape)
    assert abs(col * CELL - qx) <= 1.5 * CELL and abs(r * CELL - qy) <= 1.5 * CELL
    exact = MastSensor(hm, CLEAN, np.random.default_rng(3), (2.0, 10.0), 0.0)
    assert exact.update((7.0, 10.0, 0.0), 0.3) == (7.0, 10.0, 0.3)  # no drift: the truth


def test_a_trials_sensing_replays_bit_for_bit():
    hm = _crater()
    mission = Mission.between(4, (4.0, 5.0), (16.0, 6.0))
    cfg = PerceptionConfig(sensor="mast")
    runs = []
    for _ in range(2):
        s = make_sensing(hm, cfg, mission)
        poses = [s.update((x, 5.0 + 0.1 * x, 0.0), 0.1) for x in np.arange(4.0, 9.0, 0.05)]
        runs.append((poses, s.z))
    assert runs[0][0] == runs[1][0] and np.array_equal(runs[0][1], runs[1][1], equal_nan=True)
    oracle = make_sensing(hm, None, mission)
    assert isinstance(oracle, Oracle) and oracle.z is hm.z and oracle.update((1.0, 2.0, 3.0), 0.5) == (1.0, 2.0, 0.5)


def test_perception_keys_are_validated_and_the_sheet_gives_published_limits():
    choice = planner_from_table({"name": "astar", "sensor": "mast", "sensor_range_m": 6.0, "limits": "sheet"})
    assert choice.perception.sensor == "mast" and choice.perception.limits == "sheet"
    # the default arm: the true map and pose, with the published limits (the default since issue 42)
    assert planner_from_table({"name": "astar", "sensor": "oracle"}).perception == PerceptionConfig(limits="sheet")
    assert planner_from_table({"name": "astar", "sensor": "oracle", "limits": "measured"}).perception is None
    with pytest.raises(InputError, match="sensor"):
        PerceptionConfig(sensor="lidar")
    with pytest.raises(InputError, match="map_noise_m"):
        PerceptionConfig(sensor="mast", map_noise_m=0.05)
    from offroadbench.navigation.problem import VehicleEnvelope
    from offroadbench.sim.trial.vehicle import load_vehicle

    husky = load_vehicle("husky")
    env = sheet_envelope(VehicleEnvelope(), husky)
    assert env.max_slope == pytest.approx(math.tan(math.radians(30.0)))  # the sheet's side slope
    assert env.max_step_m == VehicleEnvelope().max_step_m  # the sheet gives no step: as measured


def test_a_study_can_put_mppi_and_the_sensor_arms_on_its_grid():
    from offroadbench.study.spec.config import plan_cells, study_from_dict

    study = study_from_dict({
        "study": {"name": "arms", "recipe": "paper-d2.45", "root_seed": 0},
        "grid": {"planner.name": ["astar", "mppi"], "planner.sensor": ["oracle", "mast"]},
        "planner": {"sensor_range_m": 6.0, "limits": "sheet"},
    })
    plans = plan_cells(study)
    arms = {(p.section("planner").name, p.section("planner").perception.sensor) for p in plans}
    assert arms == {("astar", "oracle"), ("astar", "mast"), ("mppi", "oracle"), ("mppi", "mast")}
    assert all(p.section("planner").perception.limits == "sheet" for p in plans)
    with pytest.raises(InputError, match="sensor"):
        plan_cells(study_from_dict({"study": {"name": "bad", "recipe": "paper-d2.45", "root_seed": 0},
                                    "planner": {"name": "mppi", "sensor": "radar"}}))


def test_a_planner_under_the_mast_sensor_replans_from_its_believed_position_and_replays():
    from offroadbench.sim import World
    from offroadbench.sim.trial.runner import drive_mission

    hm = Heightmap.flat(161, 161, CELL, z_m=0.3)  # 8 m square
    mission = Mission.between(0, (2.0, 2.0), (6.0, 5.0))
    choice = planner_from_table({"name": "astar", "sensor": "mast", "odometry_drift": 0.05})
    classes = np.zeros(hm.shape, dtype=np.uint8)
    with World(hm) as world:
        a = drive_mission(world, mission, planner=choice, classes=classes, border_m=1.0)
        b = drive_mission(world, mission, planner=choice, classes=classes, border_m=1.0)
    assert a.result == b.result and np.array_equal(a.path_xy, b.path_xy)
    assert len(a.path_xy) > 2  # the start, re-planning positions and the last plan
    tel = a.telemetry
    true_xy = np.column_stack([tel["x_m"], tel["y_m"]])
    # the believed path drifts from the true one (the tracker followed the believed pose)
    gap = np.hypot(*(a.belief.trail_xy[-1] - true_xy[-1]))
    assert 0.0 < gap < 1.0
