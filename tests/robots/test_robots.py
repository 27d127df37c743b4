"""``--robot``: a layer of parameters under the preset and the user's files;
the Panda's URDF read from the installed package and made loadable."""

import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from robot_controller import parameters as cfg
from robot_controller.core.model import effort_limits, joint_names, load_model
from robot_controller.parameters import consistency
from robot_controller.robots import ROBOTS, urdf_of


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_every_robot_is_a_whole_configuration_that_passes_the_checks(name):
    params = cfg.load_stack(robot=name)
    consistency.check_stack(params)  # limits, joint counts, the default trajectory's torque
    home = list(ROBOTS[name].home_position)
    assert params["trajectory_planner"]["joint_count"] == len(home)
    if name != "one_dof":
        assert params["simulator"]["initial_position"] == home
        assert params["pid_controller"]["design_position"] == home


def test_a_config_file_overrides_the_robot_per_node(tmp_path):
    path = tmp_path / "plant.yaml"
    path.write_text(f"simulator:\n  ros__parameters:\n    urdf_path: {urdf_of('planar2')}\n")
    params = cfg.load_stack(robot="panda", config=path)
    assert params["simulator"]["urdf_path"] == str(urdf_of("planar2"))
    assert params["pid_controller"]["urdf_path"] == str(urdf_of("panda"))


def test_the_panda_is_its_seven_arm_joints_with_the_urdf_effort_limits():
    model = load_model(urdf_of("panda"))
    assert joint_names(model) == [f"panda_joint{k}" for k in range(1, 8)]
    assert effort_limits(model).tolist() == [87.0] * 4 + [12.0] * 3
    assert cfg.load_stack(robot="panda")["motor_node"]["torque_max"] == [87.0] * 4 + [12.0] * 3


def test_the_panda_urdf_has_no_package_paths_and_draws_its_stl_meshes():
    root = ET.parse(urdf_of("panda")).getroot()
    meshes = [mesh.get("filename") for mesh in root.iter("mesh")]
    assert meshes and not any(name.startswith("package://") for name in meshes)
    assert all(name.endswith(".stl") for name in meshes)
    assert not [joint for joint in root.iter("joint") if joint.get("type") == "prismatic"]  # the fingers, fixed


def test_an_unknown_robot_is_one_line_naming_the_choices():
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "run", "--robot", "ur6"], capture_output=True, text=True
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert "panda" in proc.stderr and "planar2" in proc.stderr and "ur5" in proc.stderr
