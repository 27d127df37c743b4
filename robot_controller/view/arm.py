"""The arm in 3-D, from the MuJoCo model the simulator loads (``core.model.load_model``): its geoms, posed by MuJoCo's
own forward kinematics (``mj_kinematics``), drawn three times: by the TRUE angles, and by the measured and reference
ones as translucent ghosts. Each primitive is one entity with three instances, so one row moves all three; a mesh
takes one colour for all instances, so each mesh ghost is its own entity (``…/ghost_1``, ``…/ghost_2``), a little
smaller (``MESH_GHOST_SCALE``, about the mesh's centre, where MuJoCo puts its frame) so it shows only where its pose
leaves the true arm's."""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.model import joint_names, load_model
from robot_controller.core.model.mujoco_model import joint_units

MESH_GHOST_SCALE = 0.97  # a mesh's ghosts, about its centre: inside the true arm where they agree
HUB_COLOR = [70, 70, 78]
HUB_LENGTH_M, HUB_RADIUS_M = 0.06, 0.035
G = mujoco.mjtGeom
DRAWN = {int(k) for k in (G.mjGEOM_BOX, G.mjGEOM_CYLINDER, G.mjGEOM_SPHERE, G.mjGEOM_ELLIPSOID, G.mjGEOM_CAPSULE)}
DRAWN.add(int(G.mjGEOM_MESH))  # a plane or a height field is the world's, not the arm's


def entity_part(name: str) -> str:
    """An entity path part for a body's or joint's name."""
    return re.sub(r"[^A-Za-z0-9_\-]", "_", name) or "_"


def _quaternions(rotations: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_quat()  # x, y, z, w


def _z_onto(axes: np.ndarray) -> np.ndarray:
    """Quaternions (x, y, z, w) turning +z onto each unit axis (a cylinder drawn along a joint's axis)."""
    q = np.column_stack([-axes[:, 1], axes[:, 0], np.zeros(len(axes)), 1.0 + axes[:, 2]])
    q[q[:, 3] < 1e-9] = [1.0, 0.0, 0.0, 0.0]  # opposite: half a turn about x
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _mesh_path(visual_path: str, pose: int) -> str:
    """The entity of a mesh drawn in pose ``pose`` (0: true, then the ghosts)."""
    return visual_path if pose == 0 else f"{visual_path}/ghost_{pose}"


class Arm:
    """The arm's model as MuJoCo compiles ``urdf`` (a URDF or MJCF file), and what the view draws of it: its visual
    geoms (every geom if it has none apart), at ``<root>/<body>/visual_<k>``, and a hub on each joint."""

    def __init__(self, urdf: str | Path) -> None:
        self.model = model = load_model(urdf)
        self.data = mujoco.MjData(model)
        self.joint_names = joint_names(model)  #: the stack's joint order (every array's)
        self.units = joint_units(model)  #: each joint's position unit: rad, or m on a slide
        drawn = [g for g in range(model.ngeom) if int(model.geom_type[g]) in DRAWN]
        visual = [g for g in drawn if not (model.geom_contype[g] or model.geom_conaffinity[g])]
        self.geoms = visual or drawn
        counts: dict[int, int] = {}
        self.parts = []
        for g in self.geoms:
            body = int(model.geom_bodyid[g])
            k = counts[body] = counts.get(body, -1) + 1
            self.parts.append(f"{entity_part(model.body(body).name)}/visual_{k}")  #: under the root the caller names
        self.hubs = [f"hubs/{entity_part(name)}" for name in self.joint_names]
        self.base_xyz, self.sphere = self._at_zero()

    def poses(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The drawn geoms' positions ``(m, G, 3)`` and rotations ``(m, G, 3, 3)``, and the joints' anchors and axes
        ``(m, n, 3)``, for ``q`` ``(m, n)`` in the stack's joint order (rad; m on a slide)."""
        q = np.asarray(q, dtype=float)
        m, model, data = len(q), self.model, self.data
        position, rotation = np.empty((m, len(self.geoms), 3)), np.empty((m, len(self.geoms), 3, 3))
        anchor, axis = np.empty((m, model.njnt, 3)), np.empty((m, model.njnt, 3))
        for row, values in enumerate(q):
            data.qpos[model.jnt_qposadr] = values  # one 1-DoF joint each, in MuJoCo's order: the stack's
            mujoco.mj_kinematics(model, data)
            position[row], rotation[row] = data.geom_xpos[self.geoms], data.geom_xmat[self.geoms].reshape(-1, 3, 3)
            anchor[row], axis[row] = data.xanchor, data.xaxis
        return position, rotation, anchor, axis

    def _at_zero(self) -> tuple[tuple[float, float, float], tuple[np.ndarray, float]]:
        """The first joint's position at the zero pose, and the sphere the camera keeps in view: one joint, about the
        joint, holding what its link sweeps; more, about the middle of the arm at its zero pose, holding its bodies'
        frames and geoms (a stretched arm about its first joint fills half a view)."""
        position, _, anchor, _ = self.poses(np.zeros((1, self.model.njnt)))
        base = anchor[0, 0] if self.model.njnt else np.zeros(3)
        centres, extents = position[0], self.model.geom_rbound[self.geoms]
        if self.model.njnt <= 1:
            reach = np.linalg.norm(centres - base, axis=1) + extents
            return tuple(float(v) for v in base), (base, float(np.max(reach, initial=0.1)))
        points = np.vstack([self.data.xpos, anchor[0], centres])
        extents = np.r_[np.zeros(len(points) - len(centres)), extents][:, None]
        middle = 0.5 * (np.min(points - extents, axis=0) + np.max(points + extents, axis=0))
        radius = float(np.max(np.linalg.norm(points - middle, axis=1) + extents[:, 0]))
        return tuple(float(v) for v in base), (middle, radius)

    def _primitive(self, g: int, factors: list[float]):
        """The rerun archetype of geom ``g`` with one instance per radius factor (a ghost drawn a little wider
        shows around the arm), and where its rerun frame sits along the geom's z (a capsule starts at its end)."""
        import rerun as rr

        kind, size = self.model.geom_type[g], self.model.geom_size[g]
        if kind == G.mjGEOM_BOX or kind == G.mjGEOM_ELLIPSOID:
            shape = rr.Boxes3D if kind == G.mjGEOM_BOX else rr.Ellipsoids3D
            return shape, {"half_sizes": [size * f for f in factors]}, 0.0
        if kind == G.mjGEOM_SPHERE:
            return rr.Ellipsoids3D, {"half_sizes": [[size[0] * f] * 3 for f in factors]}, 0.0
        shape = rr.Cylinders3D if kind == G.mjGEOM_CYLINDER else rr.Capsules3D
        sizes = {"lengths": [2.0 * size[1]] * len(factors), "radii": [size[0] * f for f in factors]}
        return shape, sizes, 0.0 if kind == G.mjGEOM_CYLINDER else -size[1]

    def _mesh(self, g: int, colour: list[int]):
        """A mesh geom in its own frame, a triangle's vertices each with its normal as MuJoCo keeps them."""
        import rerun as rr

        model, mesh = self.model, self.model.geom_dataid[g]
        faces = slice(model.mesh_faceadr[mesh], model.mesh_faceadr[mesh] + model.mesh_facenum[mesh])
        vertices = model.mesh_vert[model.mesh_vertadr[mesh] + model.mesh_face[faces]].reshape(-1, 3)
        normals = model.mesh_normal[model.mesh_normaladr[mesh] + model.mesh_facenormal[faces]].reshape(-1, 3)
        return rr.Mesh3D(vertex_positions=vertices, vertex_normals=normals, albedo_factor=colour)

    def log_static(self, rec, root: str, poses: list[tuple[list[int], float]]) -> None:
        """What does not move: each geom's shape, one instance per pose (colour RGBA, radius factor), and the joint
        hubs of the first pose (poses: :meth:`pose_columns`)."""
        import rerun as rr

        colours, factors = [colour for colour, _ in poses], [factor for _, factor in poses]
        for g, path in zip(self.geoms, self.parts, strict=True):
            if self.model.geom_type[g] == G.mjGEOM_MESH:  # one colour a mesh: an entity per pose
                for pose, colour in enumerate(colours):
                    rec.log(_mesh_path(f"{root}/{path}", pose), self._mesh(g, colour), static=True)
            else:
                shape, sizes, _ = self._primitive(g, factors)
                rec.log(f"{root}/{path}", shape(**sizes, colors=colours, fill_mode="solid"), static=True)
        hub = rr.Cylinders3D(lengths=[HUB_LENGTH_M], radii=[HUB_RADIUS_M], colors=[HUB_COLOR], fill_mode="solid")
        for path in self.hubs:
            rec.log(f"{root}/{path}", hub, static=True)

    def pose_columns(self, root: str, q: np.ndarray) -> list[tuple[str, object]]:
        """``(entity path, columns)`` pairs for ``send_columns`` placing every geom in the rows of ``q`` ``(m, P, n)``:
        P poses (the true one first) of n joints."""
        import rerun as rr

        q = np.asarray(q, dtype=float)
        m, count, n = q.shape
        position, rotation, anchor, axis = self.poses(q.reshape(m * count, n))  # rows: sample-major, pose-minor
        out = []
        for k, (g, part) in enumerate(zip(self.geoms, self.parts, strict=True)):
            path, quaternions = f"{root}/{part}", _quaternions(rotation[:, k])
            if self.model.geom_type[g] == G.mjGEOM_MESH:
                for pose in range(count):  # rows are sample-major: every count-th row is this pose's
                    shrink = 1.0 if pose == 0 else MESH_GHOST_SCALE
                    columns = rr.InstancePoses3D.columns(
                        translations=position[pose::count, k],
                        quaternions=quaternions[pose::count],
                        scales=np.full((m, 3), shrink),
                    )
                    out.append((_mesh_path(path, pose), columns))
                continue
            shape, _, start = self._primitive(g, [1.0])
            at = position[:, k] + rotation[:, k, :, 2] * start
            where = {"translations" if shape is rr.Capsules3D else "centers": at}
            out.append((path, shape.columns(**where, quaternions=quaternions).partition([count] * m)))
        for j, part in enumerate(self.hubs):  # the hubs follow the first (true) pose
            columns = rr.Cylinders3D.columns(centers=anchor[::count, j], quaternions=_z_onto(axis[::count, j]))
            out.append((f"{root}/{part}", columns))
        return out
