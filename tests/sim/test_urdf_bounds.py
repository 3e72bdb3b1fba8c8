"""The vehicle's model file (URDF) within physical bounds, checked when the vehicle is loaded
(offroadbench.bounds.check_urdf via offroadbench.sim.trial.vehicle.load_vehicle): issue 44."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from offroadbench import resources
from offroadbench.bounds import URDF_BOUNDS, reference_lines
from offroadbench.errors import InputError
from offroadbench.sim.trial.vehicle import list_vehicles, load_vehicle

HUSKY = resources.vehicle_files()["husky"]
CHASSIS_INERTIA = '<inertia ixx="0.6022" ixy="0" ixz="0" iyy="1.7386" iyz="0" izz="2.0296"/>'


def _husky_with(tmp_path: Path, old: str, new: str) -> Path:
    """A copy of the Husky whose URDF has ``old`` replaced by ``new`` (which must occur)."""
    text = HUSKY.with_name("husky.urdf").read_text()
    assert old in text
    folder = tmp_path / "v"
    folder.mkdir(exist_ok=True)
    (folder / "husky.urdf").write_text(text.replace(old, new, 1))
    (folder / "vehicle.toml").write_text(HUSKY.read_text())
    return folder / "vehicle.toml"


def test_every_shipped_vehicle_is_within_bounds():
    for name in list_vehicles():
        load_vehicle(name)


@pytest.mark.parametrize("value, shown", [("0", "mass 0 kg"), ("1e9", "mass 1e+09 kg"), ("NaN", "mass nan kg"),
                                          ("-46", "mass -46 kg"), ("inf", "mass inf kg")])
def test_a_chassis_mass_outside_bounds_is_one_line_naming_file_and_link(tmp_path, value, shown):
    toml = _husky_with(tmp_path, '<mass value="46.034"/>', f'<mass value="{value}"/>')
    with pytest.raises(InputError) as err:
        load_vehicle(toml)
    text = str(err.value)
    assert "\n" not in text
    assert str(toml.with_name("husky.urdf")) in text and "link 'base_link'" in text and shown in text
    assert "[1e-06, 1e+06] kg" in text


@pytest.mark.parametrize("old, new, match", [
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('ixx="0.6022"', 'ixx="0"'), "not positive definite"),
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('ixx="0.6022"', 'ixx="-1"'), "not positive definite"),
    # diagonal fine, products make it indefinite: the whole tensor is judged
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('ixy="0"', 'ixy="5"'), "not positive definite"),
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('izz="2.0296"', 'izz="5"'), "triangle inequality"),
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('izz="2.0296"', 'izz="nan"'), "not finite"),
    (CHASSIS_INERTIA, CHASSIS_INERTIA.replace('0.6022', '1e9').replace('1.7386', '1e9').replace('2.0296', '1e9'),
     r"principal moment of inertia 1e\+09 kg m\^2 is outside"),
    ('<collision>\n      <geometry><box size="0.9874 0.5709 0.2475"/>',
     '<collision>\n      <geometry><box size="0.9874 -0.5709 0.2475"/>', r"box: collision size -0.5709 m"),
    ('<sphere radius="0.1651"/>', '<sphere radius="1e6"/>', r"'front_left_wheel' sphere: collision size 1e\+06 m"),
    ('<origin xyz="0 0 -0.0618" rpy="0 0 0"/>', '<origin xyz="0 0 1e5" rpy="0 0 0"/>', "centre of mass: origin offset"),
    ('<origin xyz="0.256 0.2854 -0.0910" rpy="0 0 0"/>', '<origin xyz="0.256 nan -0.0910" rpy="0 0 0"/>',
     "joint 'front_left_wheel_joint' origin: origin offset nan m"),
    ('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>', "axis is the zero vector"),
    ('<child link="front_left_wheel"/>', '<child link="no_such_link"/>', "child link 'no_such_link' is not a link"),
    ('<inertial>\n      <origin xyz="0 0 -0.0618" rpy="0 0 0"/>\n      <mass value="46.034"/>\n      '
     + CHASSIS_INERTIA + '\n    </inertial>', '', "has no <inertial>"),
    ('<joint name="front_left_wheel_joint" type="continuous">', '<joint name="front_left_wheel_joint" type="revolute">'
     '<limit lower="1" upper="-1" effort="1" velocity="1"/>', "lower 1 is above upper -1"),
    ('<joint name="front_left_wheel_joint" type="continuous">', '<joint name="front_left_wheel_joint" type="revolute">'
     '<limit lower="-100" upper="1" effort="1" velocity="1"/>', "revolute limit -100 rad is outside"),
    ('<joint name="front_left_wheel_joint" type="continuous">', '<joint name="front_left_wheel_joint" type="continuous">'
     '<limit effort="-1" velocity="1"/>', "effort -1 must be"),
    ('name="front_left_wheel_joint"', 'name="renamed_joint"', "has no joint.s. front_left_wheel_joint"),
])
def test_a_model_file_outside_bounds_is_refused_naming_it(tmp_path, old, new, match):
    toml = _husky_with(tmp_path, old, new)
    with pytest.raises(InputError, match=match) as err:
        load_vehicle(toml)
    assert "\n" not in str(err.value) and str(toml.with_name("husky.urdf")) in str(err.value)


@pytest.mark.parametrize("text, match", [
    ("this is not a URDF\n", "not a URDF that can be read .syntax error"),
    ("", "not a URDF that can be read"),
    ('<svg xmlns="http://www.w3.org/2000/svg"/>', "root element is <.*svg>, a URDF's is <robot>"),
    ('<robot name="empty"/>', "it has no <link>"),
    ('<robot name="r"><link name="a"><inertial><mass value="abc"/></inertial></link></robot>', "could not convert"),
])
def test_a_file_that_is_not_a_urdf_is_one_line_naming_it(tmp_path, text, match):
    folder = tmp_path / "v"
    folder.mkdir()
    (folder / "husky.urdf").write_text(text)
    (folder / "vehicle.toml").write_text(HUSKY.read_text())
    with pytest.raises(InputError, match=match) as err:
        load_vehicle(folder / "vehicle.toml")
    assert "\n" not in str(err.value) and str(folder / "husky.urdf") in str(err.value)


def test_the_settings_reference_prints_the_urdf_ranges():
    text = "\n".join(reference_lines())
    for name, (unit, bound) in URDF_BOUNDS.items():
        assert re.search(rf"\| {re.escape(name)} \| {re.escape(unit)} \| {re.escape(bound.text())} \|", text)
