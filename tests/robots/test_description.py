"""Any fixed-base arm from its description: mesh paths resolved, unreadable visuals replaced,
fingers and mimic joints held, contacts off, the SRDF's home pose; floating bases refused."""

import mujoco
import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.cli.main import main
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import joint_names, load_model
from robot_controller.parameters import consistency
from robot_controller.robots import arm_name, robot
from robot_controller.robots.description import ARMS, describe

OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"  # a tetrahedron
INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'


def link(name: str, mesh: str = "", visual: str = "") -> str:
    collision = f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>' if mesh else ""
    drawn = f'<visual><geometry><mesh filename="{visual}"/></geometry></visual>' if visual else ""
    return f'<link name="{name}">{INERTIAL}{drawn}{collision}</link>'


def joint(name: str, parent: str, child: str, kind: str = "revolute", extra: str = "") -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><axis xyz="0 1 0"/>'
        f'<origin xyz="0 0 0.3"/><limit lower="-1" upper="2" effort="20" velocity="2"/>{extra}</joint>'
    )


@pytest.fixture
def arm(tmp_path):
    """``my_arm/urdf/arm.urdf``: two revolute joints, a finger and a mimic joint, package:// and .dae meshes."""
    package = tmp_path / "my_arm"
    (package / "meshes").mkdir(parents=True)
    (package / "urdf").mkdir()
    (package / "meshes" / "link.obj").write_text(OBJ)
    body = "".join(
        [
            '<link name="base"/>',
            link("upper", "package://my_arm/meshes/link.obj", "package://my_arm/meshes/link.dae"),
            link("lower", "../meshes/link.obj"),
            link("finger"),
            link("twin"),
            joint("shoulder", "base", "upper"),
            joint("elbow", "upper", "lower"),
            joint("finger_joint", "lower", "finger", "prismatic"),
            joint("twin_joint", "lower", "twin", extra='<mimic joint="elbow"/>'),
        ]
    )
    path = package / "urdf" / "arm.urdf"
    path.write_text(f'<robot name="mine">{body}</robot>')
    return path


def test_a_urdf_path_loads_with_its_meshes_resolved_and_its_fingers_held(arm, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    described = describe(str(arm))
    assert described.name == "arm"
    assert "held still finger_joint, twin_joint" in described.note
    assert "1 visual(s) MuJoCo cannot read dropped, 1 collision shape(s) drawn instead" in described.note
    text = described.path.read_text()
    assert "package://" not in text and ".dae" not in text and str(arm.parent.parent / "meshes" / "link.obj") in text
    model = load_model(described.path)
    assert joint_names(model) == ["shoulder", "elbow"]
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT  # the arm's own links never collide


def test_a_package_uri_is_found_on_ros_package_path(arm, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    assert joint_names(load_model(describe("package://my_arm/urdf/arm.urdf").path)) == ["shoulder", "elbow"]
    with pytest.raises(ConfigError, match="no package 'nobody'"):
        describe("package://nobody/urdf/arm.urdf")


def test_a_missing_mesh_is_refused_naming_it(arm, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (arm.parent.parent / "meshes" / "link.obj").unlink()
    with pytest.raises(ConfigError, match="mesh 'package://my_arm/meshes/link.obj': no file"):
        describe(str(arm))


def test_the_home_pose_is_the_srdf_group_state_else_mid_range_inside_a_margin(arm, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert describe(str(arm)).home == (0.5, 0.5)  # mid-range of [-1, 2]
    (arm.parent.parent / "srdf").mkdir()
    (arm.parent.parent / "srdf" / "arm.srdf").write_text(
        '<robot name="mine"><group_state name="other" group="a"><joint name="shoulder" value="1.5"/></group_state>'
        '<group_state name="home" group="a"><joint name="shoulder" value="-1"/></group_state></robot>'
    )
    described = describe(str(arm))
    assert described.home == (-0.8, 0.5)  # the "home" state, 0.2 rad inside the limit; elbow not in it
    assert described.amplitude == (0.1, 0.4)  # half the room to the nearer limit, at most 0.4 rad


@pytest.mark.parametrize(
    ("body", "reason"),
    [
        (
            '<link name="world"/><link name="b">' + INERTIAL + "</link>" + joint("free", "world", "b", "floating"),
            "a floating base",
        ),
        ('<link name="b">' + INERTIAL + "</link>", "no movable joint"),
    ],
)
def test_a_floating_base_or_no_movable_joint_is_refused_with_the_reason(tmp_path, body, reason):
    path = tmp_path / "thing.urdf"
    path.write_text(f'<robot name="thing">{body}</robot>')
    with pytest.raises(ConfigError, match=reason):
        describe(str(path))


def test_an_srdf_floating_virtual_joint_is_a_floating_base():
    with pytest.raises(ConfigError, match="a floating base"):
        describe("a1")  # example-robot-data's quadruped, by its file name


@pytest.mark.parametrize("name", sorted(ARMS))
def test_every_listed_arm_is_a_whole_configuration_that_passes_the_checks(name):
    params = cfg.load_stack(robot=name)
    consistency.check_stack(params)
    assert params["trajectory_planner"]["offset"] == list(robot(name).home_position)
    assert arm_name(name, params["simulator"]["urdf_path"]) == name


def test_a_path_names_the_run_by_its_file_and_a_config_file_urdf_by_its_own(arm, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    params = cfg.load_stack(robot=str(arm))
    assert params["trajectory_planner"]["joint_count"] == 2
    assert arm_name(str(arm), params["simulator"]["urdf_path"]) == "arm"
    assert arm_name("one_dof", str(arm)) == "arm" and arm_name("one_dof", "") == "one_dof"


def test_the_robots_verb_lists_every_arm_with_its_joints_and_home(capsys):
    assert main(["robots"]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines() if line[:1].isalnum()}
    assert set(ARMS) | {"one_dof", "planar2"} <= set(lines)
    assert "6 joints" in lines["ur5"] and "home 0.00 -0.79 0.00 -2.36" in lines["panda"]
    assert np.isclose(float(lines["z1"].split("home ")[1].split()[1]), 0.2)
