"""Contract over every known vehicle: it loads, and its TOML agrees with its URDF (the wheel joints
exist, spin about the body's y axis, the wheel radius is the wheels' collision radius and the track
is the lateral distance between the left and right wheel joints, measured in the body frame through
any steering knuckle, rocker or bogie; the steering and differential joints exist)."""

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from offroadbench.sim.trial.vehicle import VehicleSpec, list_vehicles, load_vehicle


@pytest.mark.parametrize("name", list_vehicles())
def test_vehicle_contract(name):
    spec = load_vehicle(name)
    assert isinstance(spec, VehicleSpec) and Path(spec.urdf).is_file()
    root = ET.parse(spec.urdf).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
    joints = {j.get("name"): j for j in root.iter("joint")}
    masses = [float(m.get("value")) for link in links.values() for m in link.iter("mass")]
    assert masses and all(m > 0 for m in masses), "every inertial link has a positive mass"
    ys = {}
    for jname in spec.wheel_joints:
        joint = joints.get(jname)
        assert joint is not None, f"{name}: wheel joint {jname!r} is not in the URDF"
        assert joint.get("type") == "continuous"
        axis = np.array([float(v) for v in joint.find("axis").get("xyz").split()])
        assert np.allclose(np.abs(axis), [0, 1, 0])
        ys[jname] = _body_y(joints, joint)
        wheel = links[joint.find("child").get("link")]
        radii = [float(g.get("radius")) for c in wheel.iter("collision") for g in c.find("geometry")]
        assert radii and all(r == pytest.approx(spec.wheel_radius_m, rel=1e-6) for r in radii)
    left = np.mean([ys[j] for j in spec.left_wheel_joints])
    right = np.mean([ys[j] for j in spec.right_wheel_joints])
    assert left - right == pytest.approx(spec.track_m, rel=1e-3)
    for jname in spec.steer_joints + spec.differential_joints:
        assert joints.get(jname) is not None and joints[jname].get("type") == "revolute", jname


def _body_y(joints: dict, joint) -> float:
    """y of a joint in the root link's frame: the joint origins summed up the chain (no rotations)."""
    by_child = {j.find("child").get("link"): j for j in joints.values()}
    y = 0.0
    while joint is not None:
        origin = joint.find("origin")
        assert origin is None or not any(float(v) for v in (origin.get("rpy") or "0 0 0").split())
        y += float(origin.get("xyz").split()[1]) if origin is not None else 0.0
        joint = by_child.get(joint.find("parent").get("link"))
    return y
