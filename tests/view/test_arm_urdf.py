"""The view draws any arm from its URDF: the Franka Panda's (meshes, a chain of seven
revolute joints with rotated origins), posed as MuJoCo poses it, and its plots per joint."""

from __future__ import annotations

import importlib.metadata

import numpy as np
import pytest

from robot_controller.core.controller import state_layout
from robot_controller.view import arm as arm_view
from robot_controller.view import feed, kinematics, layout, urdf_arm
from tests.view.test_view import FakeRecording

PANDA_JOINTS = [f"panda_joint{k}" for k in range(1, 8)]
READY = np.array([0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398])


@pytest.fixture(scope="module")
def panda_urdf():
    try:
        importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    from robot_controller.robots import urdf_of

    return urdf_of("panda")


@pytest.fixture(scope="module")
def panda_arm(panda_urdf):
    from robot_controller.view.from_bag import stack_joint_order

    return urdf_arm.load_arm(panda_urdf, stack_joint_order(panda_urdf))


def test_the_panda_is_a_chain_of_seven_revolute_joints_drawn_with_meshes(panda_arm):
    assert panda_arm.joint_names == PANDA_JOINTS
    moving = [(parent, joint) for parent, joint in panda_arm.joints() if joint.kind in urdf_arm.MOVING]
    assert [joint.name for _, joint in moving] == PANDA_JOINTS
    assert all(joint.kind == "revolute" for _, joint in moving)
    for (_, before), (parent, _) in zip(moving, moving[1:], strict=False):
        assert parent is before.child  # a serial chain: each joint moves the next one's link
    assert any(joint.rpy != (0.0, 0.0, 0.0) for _, joint in moving)  # rotated origins, as a real arm has
    meshes = {link.name: v for link in panda_arm.links() for v in link.visuals if v.kind == "mesh"}
    assert {f"panda_link{k}" for k in range(8)} | {"panda_hand"} <= set(meshes)
    for visual in meshes.values():
        assert visual.mesh.is_file() and visual.mesh.suffix == ".stl"
        assert 0.0 < np.linalg.norm(visual.centre) < 0.2  # read from the file: the link's bulk, near its frame
    target, radius = kinematics.view_sphere(panda_arm)
    frames = kinematics.link_frames(panda_arm, np.zeros((1, 7)))
    assert max(np.linalg.norm(position[0] - target) for _, position in frames.values()) < radius < 0.8
    assert 0.333 < target[2] < 1.0  # about the middle of the arm (standing at its zero pose), not its first joint


def test_forward_kinematics_agree_with_mujoco_on_the_panda(panda_urdf, panda_arm):
    import mujoco

    from robot_controller.core.model import joint_names, load_model

    model = load_model(panda_urdf)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    q = np.vstack([READY, rng.uniform(-1.5, 1.5, (4, 7))])
    frames = kinematics.link_frames(panda_arm, q)
    for row, values in enumerate(q):
        for name, value in zip(joint_names(model), values, strict=True):
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_kinematics(model, data)
        for link in ("panda_link1", "panda_link4", "panda_link7", "panda_hand"):
            rotation, position = frames[link]
            body = model.body(link).id
            np.testing.assert_allclose(position[row], data.xpos[body], atol=1e-6, err_msg=link)
            np.testing.assert_allclose(rotation[row], data.xmat[body].reshape(3, 3), atol=1e-6, err_msg=link)


def test_the_panda_is_logged_mesh_by_mesh_with_its_ghosts(panda_arm):
    import rerun as rr

    logged: list[tuple[str, object]] = []

    class Log:
        def log(self, path, entry, static=False):
            logged.append((path, entry))

    arm_view.log_static(Log(), panda_arm, "world/arm", list(layout.POSES.values()))
    assets = [path for path, entry in logged if isinstance(entry, rr.Asset3D)]
    assert "world/arm/panda_link4/visual_0" in assets
    assert "world/arm/panda_link4/visual_0/ghost_1" in assets and "world/arm/panda_link4/visual_0/ghost_2" in assets
    assert len(assets) == 3 * 9  # link0…link7 and the hand, each true and two ghosts
    poses = dict(arm_view.pose_columns(panda_arm, "world/arm", np.broadcast_to(READY, (4, 3, 7))))
    assert set(assets) <= set(poses)  # every mesh entity is placed
    assert {f"world/arm/hubs/{name}" for name in PANDA_JOINTS} <= set(poses)


def test_every_joint_has_its_series_named_and_the_plots_in_tabs(panda_arm):
    live = FakeRecording()
    view = feed.ViewFeed([feed.Outlet(live, 0.0)], panda_arm, nominal_period_s=0.01, live=False)
    for k in range(300):
        t = 0.01 * k
        q = READY + 0.1 * np.sin(t + np.arange(7))
        values = {name: np.zeros(7) for name in state_layout.FIELDS} | {"reference": q, "command": np.arange(7.0)}
        view.controller_state(state_layout.encode(t, "ok", t, 7, values))
        view.true_state(t, q - 0.001, np.arange(7.0))
        view.measured(t, q)
    view.flush(final=True)
    for name in PANDA_JOINTS:
        for series in ("true", "reference", "error_true", "commanded", "applied"):
            assert live.rows(layout.series_path(series, name, 7)) > 100, (name, series)
    assert layout.series_path("error_true", "panda_joint3", 7) == "plots/error/panda_joint3/error_true"
    _, plots = layout.blueprint(panda_arm, live=True).root_container.contents
    tabs, timing = plots.contents
    assert [str(tab.name) for tab in tabs.contents] == ["all joints", *PANDA_JOINTS]
    assert str(timing.name) == "loop timing [ms]"


def test_a_prismatic_joints_plots_are_in_metres_and_newtons():
    from robot_controller.robots import urdf_of
    from robot_controller.view.from_bag import stack_joint_order

    path = urdf_of("scara")
    _, plots = layout.blueprint(urdf_arm.load_arm(path, stack_joint_order(path)), live=True).root_container.contents
    overview, shoulder, _, quill = plots.contents[0].contents
    titles = [str(view.name) for view in overview.contents]
    assert titles[0] == "tracking error, reference − true position [mrad; mm on quill]", titles
    assert titles[2] == "torque, commanded [N·m; N on quill] (colours as above)", titles
    assert [str(view.name) for view in quill.contents] == [
        "quill: position [m]",
        "quill: tracking error [mm]",
        "quill: force [N]",
    ]
    assert [str(view.name) for view in shoulder.contents][0] == "shoulder: position [rad]"
