"""The view draws any arm from its MuJoCo model: the Franka Panda's (meshes, a chain of seven
revolute joints with rotated origins), posed by MuJoCo, and its plots per joint."""

from __future__ import annotations

import importlib.metadata

import mujoco
import numpy as np
import pytest

from robot_controller.core.controller import state_layout
from robot_controller.view import arm as arm_view
from robot_controller.view import feed, layout
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
    return arm_view.Arm(panda_urdf)


def test_the_panda_is_drawn_with_its_meshes_and_framed_whole(panda_arm):
    assert panda_arm.joint_names == PANDA_JOINTS and panda_arm.units == ["rad"] * 7
    model = panda_arm.model
    meshes = {
        part.split("/")[0]
        for g, part in zip(panda_arm.geoms, panda_arm.parts, strict=True)
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
    }
    assert meshes == {f"panda_link{k}" for k in range(8)} | {"panda_hand"}
    assert all(model.geom_contype[g] == 0 for g in panda_arm.geoms)  # the visuals, not the collision shapes too
    target, radius = panda_arm.sphere
    position, _, anchor, _ = panda_arm.poses(np.zeros((1, 7)))
    assert max(np.linalg.norm(p - target) for p in [*position[0], *anchor[0]]) < radius < 0.8
    assert 0.333 < target[2] < 1.0  # about the middle of the arm (standing at its zero pose), not its first joint


def test_each_pose_is_placed_in_its_own_rows(panda_arm):
    """Rows are sample-major, pose-minor: each ghost's mesh is placed where MuJoCo poses its own joint vector."""
    rng = np.random.default_rng(3)
    q = READY + rng.uniform(-0.5, 0.5, (2, 3, 7))  # 2 samples, the true arm and two ghosts, 7 joints
    columns = dict(panda_arm.pose_columns("world/arm", q))
    model, data = panda_arm.model, mujoco.MjData(panda_arm.model)
    mesh = model.geom_dataid.tolist()
    geom = next(g for g in panda_arm.geoms if model.geom_bodyid[g] == model.body("panda_link4").id and mesh[g] >= 0)
    for pose, path in enumerate(("visual_0", "visual_0/ghost_1", "visual_0/ghost_2")):
        rows = list(columns[f"world/arm/panda_link4/{path}"])[0].as_arrow_array().to_pylist()
        translations = np.asarray(rows, dtype=float)
        for sample in range(2):
            data.qpos[:] = q[sample, pose]
            mujoco.mj_kinematics(model, data)
            np.testing.assert_allclose(translations.reshape(-1, 3)[sample], data.geom_xpos[geom], atol=1e-6)


def test_the_panda_is_logged_mesh_by_mesh_with_its_ghosts(panda_arm):
    import rerun as rr

    logged: list[tuple[str, object]] = []

    class Log:
        def log(self, path, entry, static=False):
            logged.append((path, entry))

    panda_arm.log_static(Log(), "world/arm", list(layout.POSES.values()))
    meshes = [path for path, entry in logged if isinstance(entry, rr.Mesh3D)]
    assert "world/arm/panda_link4/visual_0" in meshes
    assert "world/arm/panda_link4/visual_0/ghost_1" in meshes and "world/arm/panda_link4/visual_0/ghost_2" in meshes
    assert len(meshes) == 3 * 9  # link0…link7 and the hand, each true and two ghosts
    poses = dict(panda_arm.pose_columns("world/arm", np.broadcast_to(READY, (4, 3, 7))))
    assert set(meshes) <= set(poses)  # every mesh entity is placed
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

    _, plots = layout.blueprint(arm_view.Arm(urdf_of("scara")), live=True).root_container.contents
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
