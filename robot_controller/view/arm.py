"""The arm in 3-D, from its URDF: each link's visual geometry (box, cylinder,
sphere, or a mesh file rerun can read), placed by forward kinematics.

The URDF is read here with the standard library rather than handed to
rerun's URDF loader, so the arm can be drawn three times at once: posed by
the TRUE angles, and by the measured and the reference angles as translucent
ghosts. Each primitive (box, cylinder, sphere) is one entity with three
instances (true, measured, reference), so one row moves all three arms
together: a browser never shows one arm at a newer instant than another. A
mesh takes one colour for all its instances, so each ghost of a mesh is an
entity of its own (``…/visual_k/ghost_1``, ``…/ghost_2``), posed by the same
send, translucent and a little smaller (``MESH_GHOST_SCALE``): a shell
around a mesh would tint the whole arm, a ghost inside it shows only where
its pose leaves the true arm's. The joint order is MuJoCo's
(``core.plant.joint_names``), the stack's order for every array.

Longer than our ~250-line guideline: a URDF reader and forward kinematics for the ghosts.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MOVING = ("revolute", "continuous", "prismatic")
MESH_FORMATS = (".stl", ".obj", ".glb", ".gltf")  # what rerun's Asset3D reads (not COLLADA's .dae)


@dataclass(frozen=True)
class Visual:
    kind: str  #: box, cylinder, sphere, mesh
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    size: tuple[float, ...] = ()  #: box (x, y, z); cylinder (radius, length); sphere (radius,); mesh scale
    mesh: Path | None = None
    #: a mesh's bounding-box centre in its own frame, unscaled (its ghosts shrink about it); 0 if unknown
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class Link:
    name: str
    visuals: list[Visual] = field(default_factory=list)
    children: list[Joint] = field(default_factory=list)


@dataclass
class Joint:
    name: str
    kind: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    child: Link


@dataclass
class ArmModel:
    root: Link
    joint_names: list[str]  #: the moving joints, in the stack's order
    reach_m: float  #: how far the arm can reach from its first joint (for the camera)
    base_xyz: tuple[float, float, float]  #: the first joint's position in the world

    def joints(self) -> list[tuple[Link, Joint]]:
        """Every joint with its parent link, parents before children."""
        out: list[tuple[Link, Joint]] = []

        def walk(link: Link) -> None:
            for joint in link.children:
                out.append((link, joint))
                walk(joint.child)

        walk(self.root)
        return out

    def links(self) -> list[Link]:
        return [self.root] + [joint.child for _, joint in self.joints()]


def _floats(text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    if not text:
        return default
    return tuple(float(v) for v in text.split())


def entity_part(name: str) -> str:
    """An entity path part for a URDF name."""
    return re.sub(r"[^A-Za-z0-9_\-]", "_", name) or "_"


def _resolve_mesh(filename: str, urdf_dir: Path) -> Path | None:
    name = re.sub(r"^(package|file)://", "", filename)
    for candidate in (Path(name), urdf_dir / name, urdf_dir / Path(name).name):
        if candidate.is_file() and candidate.suffix.lower() in MESH_FORMATS:
            return candidate
    return None


def _visuals(link: ET.Element, urdf_dir: Path) -> list[Visual]:
    out = []
    for visual in link.findall("visual"):
        origin = visual.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0))
        rpy = _floats(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0))
        geometry = visual.find("geometry")
        if geometry is None:
            continue
        for shape in geometry:
            if shape.tag == "box":
                out.append(Visual("box", xyz, rpy, _floats(shape.get("size"), (0.1, 0.1, 0.1))))
            elif shape.tag == "cylinder":
                out.append(
                    Visual("cylinder", xyz, rpy, (float(shape.get("radius", 0.02)), float(shape.get("length", 0.1))))
                )
            elif shape.tag == "sphere":
                out.append(Visual("sphere", xyz, rpy, (float(shape.get("radius", 0.02)),)))
            elif shape.tag == "mesh":
                mesh = _resolve_mesh(shape.get("filename", ""), urdf_dir)
                if mesh is not None:
                    scale = _floats(shape.get("scale"), (1.0, 1.0, 1.0))
                    out.append(Visual("mesh", xyz, rpy, scale, mesh, _mesh_centre(mesh)))
    return out


def _mesh_centre(path: Path) -> tuple[float, float, float]:
    """The centre of an STL mesh's bounding box (binary or ASCII); the origin for other formats."""
    if path.suffix.lower() != ".stl":
        return (0.0, 0.0, 0.0)
    data = path.read_bytes()
    count = int.from_bytes(data[80:84], "little") if len(data) >= 84 else -1
    if len(data) == 84 + 50 * count:  # binary: per triangle a normal, three vertices, two spare bytes
        records = np.frombuffer(data, dtype=np.uint8, offset=84).reshape(count, 50)
        vertices = records[:, 12:48].copy().view("<f4").reshape(-1, 3)
    else:
        numbers = re.findall(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", data)
        vertices = np.array(numbers, dtype=float).reshape(-1, 3)
    if len(vertices) == 0:
        return (0.0, 0.0, 0.0)
    centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    return (float(centre[0]), float(centre[1]), float(centre[2]))


def load_arm(urdf: Path, joint_order: list[str] | None = None) -> ArmModel:
    """The URDF's link tree. ``joint_order``: the stack's joint names (default:
    the moving joints as the tree lists them)."""
    tree = ET.parse(urdf).getroot()
    links = {e.get("name"): Link(e.get("name"), _visuals(e, urdf.parent)) for e in tree.findall("link")}
    children: set[str] = set()
    joints: list[Joint] = []
    for e in tree.findall("joint"):
        origin = e.find("origin")
        axis = e.find("axis")
        parent, child = e.find("parent").get("link"), e.find("child").get("link")
        raw_axis = np.array(_floats(axis.get("xyz") if axis is not None else None, (1.0, 0.0, 0.0)))
        norm = float(np.linalg.norm(raw_axis)) or 1.0
        joint = Joint(
            e.get("name"),
            e.get("type", "fixed"),
            _floats(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0)),
            _floats(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0)),
            tuple(float(v) for v in raw_axis / norm),
            links[child],
        )
        links[parent].children.append(joint)
        children.add(child)
        joints.append(joint)
    roots = [link for name, link in links.items() if name not in children]
    if len(roots) != 1:
        raise ValueError(f"{urdf}: expected one root link, found {len(roots)}")
    moving = [j.name for j in joints if j.kind in MOVING]
    order = list(joint_order) if joint_order else moving
    missing = [name for name in order if name not in moving]
    if missing:
        raise ValueError(f"{urdf}: no moving joint named {missing}")
    first = next((j for j in joints if j.kind in MOVING), joints[0] if joints else None)
    reach = sum(float(np.linalg.norm(j.xyz)) for j in joints if j is not first) + max(
        (_extent(v) for link in links.values() for v in link.visuals), default=0.1
    )
    base = first.xyz if first is not None else (0.0, 0.0, 0.0)
    return ArmModel(roots[0], order, reach, base)


def _extent(visual: Visual) -> float:
    """How far the visual reaches from its link's origin, roughly."""
    offset = float(np.linalg.norm(visual.xyz))
    if visual.kind == "box":
        return offset + 0.5 * float(np.linalg.norm(visual.size))
    if visual.kind == "cylinder":
        return offset + 0.5 * visual.size[1] + visual.size[0]
    if visual.kind == "sphere":
        return offset + visual.size[0]
    return offset + 0.1


def rpy_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def z_to(axis: tuple[float, float, float]) -> np.ndarray:
    """The ``xyzw`` quaternion turning +z onto ``axis`` (a cylinder drawn along a joint axis)."""
    a = np.asarray(axis, dtype=float)
    v = np.cross([0.0, 0.0, 1.0], a)
    w = 1.0 + a[2]
    if w < 1e-9:  # opposite: half a turn about x
        return np.array([1.0, 0.0, 0.0, 0.0])
    q = np.array([v[0], v[1], v[2], w])
    return q / np.linalg.norm(q)


def axis_matrices(axis: tuple[float, float, float], angles: np.ndarray) -> np.ndarray:
    """Rotations by ``angles`` about the unit ``axis`` (Rodrigues), shape ``(m, 3, 3)``."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    angles = np.asarray(angles, dtype=float)[:, None, None]
    return np.eye(3) + np.sin(angles) * k + (1.0 - np.cos(angles)) * (k @ k)


def link_frames(arm: ArmModel, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Forward kinematics: each link's frame in the world, ``(R (m, 3, 3), p (m, 3))``, for
    ``m`` joint vectors ``q`` (``(m, n)``, the stack's joint order). Also ``"<joint>@"``: a
    moving joint's frame before its motion (where its axis sits)."""
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
            frames[joint.child.name] = (
                at_joint[0],
                at_joint[1] + at_joint[0] @ np.asarray(joint.axis) * value[:, None],
            )
        else:
            frames[joint.child.name] = at_joint
        if joint.kind in MOVING:
            frames[f"{joint.name}@"] = at_joint
    return frames


def view_sphere(arm: ArmModel) -> tuple[np.ndarray, float]:
    """Where the camera looks (the first joint) and how large a sphere about it must stay in
    view (m): one joint, its reach; more, how far the arm reaches from the first joint at its
    zero pose (the links' origins and visuals; the summed lengths of a folding chain overstate it)."""
    base = np.asarray(arm.base_xyz, dtype=float)
    if len(arm.joint_names) <= 1:
        return base, arm.reach_m
    frames = link_frames(arm, np.zeros((1, len(arm.joint_names))))
    radius = 0.0
    for link in arm.links():
        rotation, position = frames[link.name]
        radius = max(radius, float(np.linalg.norm(position[0] - base)))
        for v in link.visuals:
            centre = position[0] + rotation[0] @ np.asarray(v.xyz)
            radius = max(radius, float(np.linalg.norm(centre - base)) + _extent(v) - float(np.linalg.norm(v.xyz)))
    return base, radius


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


def log_static(rec, arm: ArmModel, root: str, poses: list[tuple[list[int], float]]) -> None:
    """What does not move: each visual's shape, one instance per pose (colour RGBA,
    radius factor: a ghost drawn a little wider shows around the solid arm), and the
    joint hubs of the first pose. Poses are logged with :func:`pose_columns`."""
    import rerun as rr

    colors = [colour for colour, _ in poses]
    for link in arm.links():
        for k, v in enumerate(link.visuals):
            path = _visual_path(root, link, k)
            if v.kind == "box":
                rec.log(
                    path,
                    rr.Boxes3D(
                        half_sizes=[[0.5 * s * f for s in v.size] for _, f in poses], colors=colors, fill_mode="solid"
                    ),
                    static=True,
                )
            elif v.kind == "cylinder":
                rec.log(
                    path,
                    rr.Cylinders3D(
                        lengths=[v.size[1]] * len(poses),
                        radii=[v.size[0] * f for _, f in poses],
                        colors=colors,
                        fill_mode="solid",
                    ),
                    static=True,
                )
            elif v.kind == "sphere":
                rec.log(
                    path,
                    rr.Ellipsoids3D(
                        half_sizes=[[v.size[0] * f] * 3 for _, f in poses], colors=colors, fill_mode="solid"
                    ),
                    static=True,
                )
            elif v.kind == "mesh" and v.mesh is not None:  # one colour a mesh: an entity per pose
                for k_pose, colour in enumerate(colors):
                    rec.log(_mesh_path(path, k_pose), rr.Asset3D(path=v.mesh, albedo_factor=colour), static=True)
    for _, joint in arm.joints():
        if joint.kind in MOVING:
            rec.log(
                _hub_path(root, joint),
                rr.Cylinders3D(lengths=[HUB_LENGTH_M], radii=[HUB_RADIUS_M], colors=[HUB_COLOR], fill_mode="solid"),
                static=True,
            )


def pose_columns(arm: ArmModel, root: str, q: np.ndarray) -> list[tuple[str, object]]:
    """Columns placing every visual for ``m`` rows of poses: ``q`` is ``(m, P, n)``, P
    poses (true first) of n joints. Returns ``(entity path, columns)`` pairs for ``send_columns``."""
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
            if v.kind == "box":
                columns = rr.Boxes3D.columns(centers=centers, quaternions=quaternions)
            elif v.kind == "cylinder":
                columns = rr.Cylinders3D.columns(centers=centers, quaternions=quaternions)
            elif v.kind == "sphere":
                columns = rr.Ellipsoids3D.columns(centers=centers, quaternions=quaternions)
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
                continue
            else:
                continue
            out.append((_visual_path(root, link, k), columns.partition([count] * m)))
    for _, joint in arm.joints():  # the hubs follow the first (true) pose
        if joint.kind in MOVING:
            rotation, position = frames[f"{joint.name}@"]
            hub = rotation[::count] @ z_to_matrix(joint.axis)
            out.append(
                (
                    _hub_path(root, joint),
                    rr.Cylinders3D.columns(centers=position[::count], quaternions=_quaternions(hub)),
                )
            )
    return out


def z_to_matrix(axis: tuple[float, float, float]) -> np.ndarray:
    """The rotation matrix turning +z onto ``axis``."""
    x, y, z, w = z_to(axis)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
