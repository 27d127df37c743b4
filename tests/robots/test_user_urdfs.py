"""URDFs as a user writes them: a massless link between two joints (a gimbal's yoke) loads."""

import re

import mujoco
import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.robots.description import describe

INERTIAL = (
    '<inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>'
)
LIMIT = '<limit lower="-1" upper="1" effort="10" velocity="2"/>'
GIMBAL = f"""<robot name="gimbal"><link name="base"/>
<joint name="pan" type="revolute"><parent link="base"/><child link="yoke"/><axis xyz="0 0 1"/>{LIMIT}</joint>
<link name="yoke"/>
<joint name="tilt" type="revolute"><parent link="yoke"/><child link="head"/><axis xyz="0 1 0"/>{LIMIT}</joint>
<link name="head">{INERTIAL}</link></robot>"""


def test_a_massless_link_a_joint_moves_loads_with_a_negligible_mass_and_is_said(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (path := tmp_path / "gimbal.urdf").write_text(GIMBAL)
    described = describe(str(path))
    model = mujoco.MjModel.from_xml_path(str(described.path))  # MuJoCo refused 'yoke': mass below mjMINVAL
    yoke = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "yoke")
    assert 0 < model.body_mass[yoke] <= 1e-6
    assert np.isclose(model.body_mass.sum(), 0.5, atol=1e-5)  # the arm's mass is the URDF's
    assert "yoke" in described.note


@pytest.mark.parametrize(
    ("filename", "reason"),
    [("arm.urdf.xacro", "xacro arm.urdf.xacro > arm.urdf"), ("arm.sdf", "not a URDF (.urdf) or MJCF (.xml, .mjcf)")],
)
def test_a_file_of_another_kind_is_refused_saying_what_it_is(tmp_path, filename, reason):
    (path := tmp_path / filename).write_text(GIMBAL)
    with pytest.raises(ConfigError, match=re.escape(reason)):
        describe(str(path))


def test_a_link_with_collision_shapes_and_no_inertial_is_said_to_weigh_as_water(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    box = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    mount = '<joint name="mount" type="fixed"><parent link="head"/><child link="tool"/></joint>'
    tool = f'{mount}<link name="tool">{box}</link>'
    (path := tmp_path / "gimbal.urdf").write_text(GIMBAL.replace("</robot>", f"{tool}</robot>"))
    described = describe(str(path))
    model = mujoco.MjModel.from_xml_path(str(described.path))
    assert np.isclose(model.body_mass[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "tool")], 1.0)  # MuJoCo's
    assert "tool: no <inertial>, mass from its collision shapes at 1000 kg/m³" in described.note
