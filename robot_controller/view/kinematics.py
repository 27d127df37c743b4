"""Forward kinematics of an arm read from its URDF (``urdf_arm``): each link's frame for many joint vectors at once, the
rotations the URDF and the view need, and the sphere the camera keeps in view."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from robot_controller.view.urdf_arm import MOVING, ArmModel, visual_extent


def rpy_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return Rotation.from_euler("xyz", rpy).as_matrix()


def axis_matrices(axis: tuple[float, float, float], angles: np.ndarray) -> np.ndarray:
    """Rotations by ``angles`` (rad) about the unit ``axis``, shape ``(m, 3, 3)``."""
    return Rotation.from_rotvec(np.outer(np.asarray(angles, dtype=float), axis)).as_matrix()


def z_to_matrix(axis: tuple[float, float, float]) -> np.ndarray:
    """The rotation turning +z onto the unit ``axis`` (a cylinder drawn along a joint axis)."""
    a = np.asarray(axis, dtype=float)
    if a[2] < -1.0 + 1e-9:  # opposite: half a turn about x
        return np.diag([1.0, -1.0, -1.0])
    return Rotation.from_quat([*np.cross([0.0, 0.0, 1.0], a), 1.0 + a[2]]).as_matrix()


def link_frames(arm: ArmModel, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Forward kinematics: each link's frame in the world, ``(R (m, 3, 3), p (m, 3) in m)``; also
    ``"<joint>@"``, a moving joint's frame before its motion (where its axis sits).

    :param q: ``(m, n)`` joint vectors in the stack's joint order, rad (m for a prismatic joint)
    """
    q = np.asarray(q, dtype=float)
    m = len(q)
    index = {name: k for k, name in enumerate(arm.joint_names)}
    frames = {arm.root.name: (np.broadcast_to(np.eye(3), (m, 3, 3)), np.zeros((m, 3)))}
    for parent, joint in arm.joints():
        rotation, position = frames[parent.name]
        at_joint = (rotation @ rpy_matrix(joint.rpy), position + rotation @ np.asarray(joint.xyz))
        value = q[:, index[joint.name]] if joint.name in index else np.zeros(m)
        if joint.kind in ("revolute", "continuous"):
            frames[joint.child.name] = (at_joint[0] @ axis_matrices(joint.axis, value), at_joint[1])
        elif joint.kind == "prismatic":
            slide = at_joint[0] @ np.asarray(joint.axis) * value[:, None]
            frames[joint.child.name] = (at_joint[0], at_joint[1] + slide)
        else:
            frames[joint.child.name] = at_joint
        if joint.kind in MOVING:
            frames[f"{joint.name}@"] = at_joint
    return frames


def view_sphere(arm: ArmModel) -> tuple[np.ndarray, float]:
    """Where the camera looks and the radius (m) about it to keep in view: one joint, the joint and its reach (the
    link swings about it); more, the middle of the arm at its zero pose and the radius that holds its frames and
    shapes (a folding chain's summed lengths overstate it; a stretched arm about its first joint fills half a view)."""
    base = np.asarray(arm.base_xyz, dtype=float)
    if len(arm.joint_names) <= 1:
        return base, arm.reach_m
    frames = link_frames(arm, np.zeros((1, len(arm.joint_names))))
    points, extents = [base], [0.0]  # each frame and shape's centre, and how far the shape reaches beyond it
    for link in arm.links():
        rotation, position = frames[link.name]
        points += [position[0]] + [position[0] + rotation[0] @ np.asarray(v.xyz) for v in link.visuals]
        extents += [0.0] + [max(0.0, visual_extent(v) - float(np.linalg.norm(v.xyz))) for v in link.visuals]
    points, extents = np.array(points), np.array(extents)[:, None]
    middle = 0.5 * (np.min(points - extents, axis=0) + np.max(points + extents, axis=0))
    return middle, float(np.max(np.linalg.norm(points - middle, axis=1) + extents[:, 0]))
