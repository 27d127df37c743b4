"""The arm in 3-D (``urdf_arm``, posed by ``kinematics``), drawn three times: by the TRUE angles, and by the measured
and reference ones as translucent ghosts. Each primitive is one entity with three instances, so one row moves all three;
a mesh takes one colour for all instances, so each mesh ghost is its own entity (``…/ghost_1``, ``…/ghost_2``), a little
smaller (``MESH_GHOST_SCALE``) so it shows only where its pose leaves the true arm's."""

from __future__ import annotations

import numpy as np

from robot_controller.view.kinematics import link_frames, rpy_matrix, z_to_matrix
from robot_controller.view.urdf_arm import MOVING, ArmModel, Joint, Link, Visual, entity_part


def _quaternions(rotations: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_quat()  # x, y, z, w


def _visual_path(root: str, link: Link, k: int) -> str:
    return f"{root}/{entity_part(link.name)}/visual_{k}"


def _mesh_path(visual_path: str, pose: int) -> str:
    """The entity of a mesh drawn in pose ``pose`` (0: true, then the ghosts)."""
    return visual_path if pose == 0 else f"{visual_path}/ghost_{pose}"


def _hub_path(root: str, joint: Joint) -> str:
    return f"{root}/hubs/{entity_part(joint.name)}"


MESH_GHOST_SCALE = 0.97  # a mesh's ghosts, about the visual's origin: inside the true arm where they agree
HUB_COLOR = [70, 70, 78]
HUB_LENGTH_M, HUB_RADIUS_M = 0.06, 0.035
PRIMITIVES = ("box", "cylinder", "sphere")


def _shape(kind: str):
    """The rerun archetype drawing a primitive URDF shape."""
    import rerun as rr

    return {"box": rr.Boxes3D, "cylinder": rr.Cylinders3D, "sphere": rr.Ellipsoids3D}[kind]


def _primitive(v: Visual, poses: list[tuple[list[int], float]]) -> dict:
    """A primitive's size for each pose (radius factor ``f``: a ghost drawn a little wider shows around the arm)."""
    if v.kind == "box":
        return {"half_sizes": [[0.5 * s * f for s in v.size] for _, f in poses]}
    if v.kind == "cylinder":
        return {"lengths": [v.size[1]] * len(poses), "radii": [v.size[0] * f for _, f in poses]}
    return {"half_sizes": [[v.size[0] * f] * 3 for _, f in poses]}


def log_static(rec, arm: ArmModel, root: str, poses: list[tuple[list[int], float]]) -> None:
    """What does not move: each visual's shape, one instance per pose (colour RGBA, radius factor), and the joint
    hubs of the first pose (poses: :func:`pose_columns`)."""
    import rerun as rr

    colors = [colour for colour, _ in poses]
    for link in arm.links():
        for k, v in enumerate(link.visuals):
            path = _visual_path(root, link, k)
            if v.kind in PRIMITIVES:
                rec.log(path, _shape(v.kind)(**_primitive(v, poses), colors=colors, fill_mode="solid"), static=True)
            elif v.kind == "mesh" and v.mesh is not None:  # one colour a mesh: an entity per pose
                for k_pose, colour in enumerate(colors):
                    rec.log(_mesh_path(path, k_pose), rr.Asset3D(path=v.mesh, albedo_factor=colour), static=True)
    hub = rr.Cylinders3D(lengths=[HUB_LENGTH_M], radii=[HUB_RADIUS_M], colors=[HUB_COLOR], fill_mode="solid")
    for _, joint in arm.joints():
        if joint.kind in MOVING:
            rec.log(_hub_path(root, joint), hub, static=True)


def pose_columns(arm: ArmModel, root: str, q: np.ndarray) -> list[tuple[str, object]]:
    """``(entity path, columns)`` pairs for ``send_columns`` placing every visual in ``m`` rows of poses.

    :param q: ``(m, P, n)``: P poses (the true one first) of n joints, rad
    """
    import rerun as rr

    q = np.asarray(q, dtype=float)
    m, count, n = q.shape
    frames = link_frames(arm, q.reshape(m * count, n))  # rows: sample-major, pose-minor
    out = []
    for link in arm.links():
        rotation, position = frames[link.name]
        for k, v in enumerate(link.visuals):
            visual_rotation = rotation @ rpy_matrix(v.rpy)
            centers = position + rotation @ np.asarray(v.xyz)
            quaternions = _quaternions(visual_rotation)
            if v.kind in PRIMITIVES:
                columns = _shape(v.kind).columns(centers=centers, quaternions=quaternions)
                out.append((_visual_path(root, link, k), columns.partition([count] * m)))
            elif v.kind == "mesh" and v.mesh is not None:
                for pose in range(count):  # rows are sample-major: every count-th row is this pose's
                    shrink = 1.0 if pose == 0 else MESH_GHOST_SCALE
                    # Shrunk about the mesh's centre, which then stays where the full-size one has it.
                    offset = visual_rotation[pose::count] @ ((1.0 - shrink) * np.asarray(v.size) * v.centre)
                    columns = rr.InstancePoses3D.columns(
                        translations=centers[pose::count] + offset,
                        quaternions=quaternions[pose::count],
                        scales=np.broadcast_to(np.asarray(v.size) * shrink, (m, 3)),
                    )
                    out.append((_mesh_path(_visual_path(root, link, k), pose), columns))
    for _, joint in arm.joints():  # the hubs follow the first (true) pose
        if joint.kind in MOVING:
            rotation, position = frames[f"{joint.name}@"]
            hub = rotation[::count] @ z_to_matrix(joint.axis)
            columns = rr.Cylinders3D.columns(centers=position[::count], quaternions=_quaternions(hub))
            out.append((_hub_path(root, joint), columns))
    return out
