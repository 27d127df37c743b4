"""An arm's URDF read with the standard library: its links' visual geometry (box, cylinder, sphere, or a mesh file rerun
can read) and its joints, in the stack's joint order (MuJoCo's, ``core.plant.joint_names``). Read here rather than by
rerun's URDF loader so the view can pose the arm three times at once (``arm``)."""

from __future__ import annotations

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


def _origin(element: ET.Element) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """An element's ``<origin>``: xyz (m) and rpy (rad), zero if absent."""
    origin = element.find("origin")
    attributes = {} if origin is None else origin.attrib
    return _floats(attributes.get("xyz"), (0.0, 0.0, 0.0)), _floats(attributes.get("rpy"), (0.0, 0.0, 0.0))


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
        xyz, rpy = _origin(visual)
        geometry = visual.find("geometry")
        if geometry is None:
            continue
        for shape in geometry:
            if shape.tag == "box":
                out.append(Visual("box", xyz, rpy, _floats(shape.get("size"), (0.1, 0.1, 0.1))))
            elif shape.tag == "cylinder":
                size = (float(shape.get("radius", 0.02)), float(shape.get("length", 0.1)))
                out.append(Visual("cylinder", xyz, rpy, size))
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
    """The URDF's link tree; ``joint_order``: the stack's joint names (default: the moving joints in tree order)."""
    tree = ET.parse(urdf).getroot()
    links = {e.get("name"): Link(e.get("name"), _visuals(e, urdf.parent)) for e in tree.findall("link")}
    children: set[str] = set()
    joints: list[Joint] = []
    for e in tree.findall("joint"):
        axis = e.find("axis")
        parent, child = e.find("parent").get("link"), e.find("child").get("link")
        raw_axis = np.array(_floats(axis.get("xyz") if axis is not None else None, (1.0, 0.0, 0.0)))
        norm = float(np.linalg.norm(raw_axis)) or 1.0
        unit_axis = tuple(float(v) for v in raw_axis / norm)
        joint = Joint(e.get("name"), e.get("type", "fixed"), *_origin(e), unit_axis, links[child])
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
        (visual_extent(v) for link in links.values() for v in link.visuals), default=0.1
    )
    base = first.xyz if first is not None else (0.0, 0.0, 0.0)
    return ArmModel(roots[0], order, reach, base)


def visual_extent(visual: Visual) -> float:
    """How far the visual reaches from its link's origin, roughly."""
    offset = float(np.linalg.norm(visual.xyz))
    if visual.kind == "box":
        return offset + 0.5 * float(np.linalg.norm(visual.size))
    if visual.kind == "cylinder":
        return offset + 0.5 * visual.size[1] + visual.size[0]
    if visual.kind == "sphere":
        return offset + visual.size[0]
    return offset + 0.1
