"""The robots ``--robot`` selects, each a parameter layer over the schema's defaults and under the preset and the
user's files: a URDF, a home pose and a default sine about it within its limits; four built in, any other from its
description. It sets no torque limit: an empty ``torque_max`` is each joint's URDF effort limit.

A fixed-base arm from its description: an arm of example-robot-data by name, a URDF or MJCF file, or a
``package://`` URI. A URDF is copied to the user's cache with its mesh paths resolved (example-robot-data,
``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, the file's own folders), the visuals MuJoCo cannot read (COLLADA)
replaced by the link's collision shapes or dropped, fingers and mimic joints fixed (their mass stays in the
arm), and contacts off unless its own ``<mujoco>`` sets options: the arm meets no world, and its links
meeting under a commanded sine are the description's artefact. An MJCF file is loaded as it is.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import resources
from robot_controller.core.errors import ConfigError

PACKAGE = "package://"
#: The arms of example-robot-data that MuJoCo loads once resolved, under its ``robots/`` folder.
ARMS = {
    "kinova": "kinova_description/robots/kinova.urdf",  # COLLADA meshes only: it runs, the view draws no shape
    "panda": "panda_description/urdf/panda.urdf",
    "so100": "so_arm_description/urdf/so100.urdf",
    "so101": "so_arm_description/urdf/so101.urdf",
    "talos_left_arm": "talos_data/robots/talos_left_arm.urdf",
    "ur3": "ur_description/urdf/ur3_robot.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "ur10": "ur_description/urdf/ur10_robot.urdf",
    "xarm7": "xarm_description/urdf/xarm7.urdf",
    "z1": "z1_description/urdf/z1.urdf",
}
READABLE_MESHES = (".stl", ".obj", ".msh")
HOME_STATES = ("ready", "home", "default")  # an SRDF's group states, the first found is the home pose
HELD = re.compile(r"finger|gripper|jaw", re.IGNORECASE)  # joints the loop does not drive, by name
AMPLITUDE_RAD = 0.4  # of the default sine, at most half the room between the home pose and the nearer limit
HOME_MARGIN_RAD = 0.2  # the home pose's least distance to a limit (a tenth of a narrower range)


@dataclass(frozen=True)
class Description:
    """:param path: the file MuJoCo loads; :param home, amplitude: rad (m) per joint; :param note: what was changed"""

    name: str
    path: Path
    home: tuple[float, ...]
    amplitude: tuple[float, ...]
    note: str


def example_share() -> Path | None:
    try:  # the package installs its robots/ under a cmeel prefix
        return Path(str(importlib.metadata.distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    except importlib.metadata.PackageNotFoundError:
        return None


def resolve(filename: str, near: Path) -> Path:
    """A description's file name (``package://``, ``file://`` or relative to the file ``near``) as a path."""
    if not filename.startswith(PACKAGE):
        path = Path(filename.removeprefix("file://")).expanduser()
        return path if path.is_absolute() else near.parent / path
    package, _, rest = filename.removeprefix(PACKAGE).partition("/")
    roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    roots += [Path(p) / "share" for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    candidates = [p for p in near.parents if p.name == package] + [r for r in roots if r.name == package]
    candidates += [root / package for root in [*roots, example_share() or Path("/nonexistent")]]
    if (folder := next((c for c in candidates if c.is_dir()), None)) is None:
        where = "above the file, on ROS_PACKAGE_PATH, under AMENT_PREFIX_PATH or in example-robot-data"
        raise ConfigError(f"{filename}: no package {package!r} {where}")
    return folder / rest


def source_of(robot: str, known: Iterable[str]) -> tuple[str, Path]:
    """The arm's name and file: a name of ``ARMS``, a path, a ``package://`` URI, another example-robot-data
    URDF's file name (tried, and refused with its reason if it cannot run); else an error naming ``known``."""
    share = example_share()
    if robot.startswith(PACKAGE) or Path(robot).suffix.lower() in (".urdf", ".xml", ".mjcf"):
        if not (path := resolve(robot, Path.cwd() / "robot").resolve()).is_file():
            raise ConfigError(f"--robot {robot}: no such file {str(path)!r}")
        return path.stem, path
    if share is not None and robot in ARMS:
        return robot, share / "example-robot-data" / "robots" / ARMS[robot]
    plain = share is not None and re.fullmatch(r"[\w.-]+", robot)
    if found := sorted(share.glob(f"example-robot-data/robots/*/*/{robot}.urdf")) if plain else []:
        return robot, found[0]
    if (path := Path(robot).expanduser()).is_file():  # a file of another kind: say what it is, not "unknown"
        if path.suffix.lower() == ".xacro":
            raise ConfigError(f"--robot {robot}: a xacro file; expand it first: xacro {path.name} > {path.stem}")
        raise ConfigError(f"--robot {robot}: not a URDF (.urdf) or MJCF (.xml, .mjcf) file")
    names = sorted({*known, *ARMS})
    raise ConfigError(f"--robot: unknown robot {robot!r}; robots are {names}, a URDF or MJCF path, or package://…")


def describe(robot: str, known: Iterable[str] = ()) -> Description:
    """The arm ``robot`` names (:func:`source_of`) made loadable, its home pose and default sine; a ConfigError
    for a missing file, a floating base, no movable joint, a model MuJoCo refuses."""
    from robot_controller.core.model.joint_limits import joint_limits

    name, source = source_of(robot, known)
    root = _parsed(source)
    srdf = _srdf_beside(source, root.get("name", ""))
    path, note = source, ""
    if root.tag == "robot":
        joints = [*root.iter("joint"), *([] if srdf is None else srdf.iter("virtual_joint"))]
        if floating := [j.get("name") for j in joints if j.get("type") in ("floating", "planar")]:
            raise ConfigError(f"--robot {robot}: a floating base (joint {floating[0]!r}); only fixed-base arms run")
        note = _made_loadable(root, source)
        digest = "" if robot in ARMS else "-" + hashlib.sha1(str(source).encode()).hexdigest()[:8]
        path = _cached(f"{name}{digest}.urdf", ET.tostring(root, encoding="unicode"))
    limits = joint_limits(path)
    if not limits.joint_names:
        raise ConfigError(f"--robot {robot}: no movable joint in {str(source)!r}")
    home = _home(srdf, limits.joint_names, limits.lower, limits.upper)
    room = np.minimum(home - limits.lower, limits.upper - home)
    amplitude = tuple(float(a) for a in np.round(np.minimum(AMPLITUDE_RAD, 0.5 * room), 3))
    return Description(name, path, tuple(float(q) for q in home), amplitude, note and f"{name}: {note}")


def _made_loadable(root: ET.Element, source: Path) -> str:
    """Rewrite the URDF ``root`` in place as the module's docstring says; what was changed, in a phrase."""
    held = []
    for joint in root.iter("joint"):
        if _moves(joint) and (joint.find("mimic") is not None or HELD.search(joint.get("name", ""))):
            held.append(joint.get("name", ""))
            joint.set("type", "fixed")
            for element in [*joint.iter("limit"), *joint.iter("dynamics"), *joint.iter("mimic")]:
                joint.remove(element)
    for mesh in root.iter("mesh"):
        path = resolve(filename := mesh.get("filename", ""), source)
        if path.suffix.lower() in READABLE_MESHES and not path.is_file():
            raise ConfigError(f"{source.name}: mesh {filename!r}: no file {str(path)!r}")
        mesh.set("filename", str(path))
    dropped = replaced = 0
    for link in root.iter("link"):
        unread = [e for e in [*link.iter("visual"), *link.iter("collision")] if not _readable(e)]
        for element in unread:
            link.remove(element)
        dropped += (lost := sum(e.tag == "visual" for e in unread))
        if lost and link.find("visual") is None:  # the collision shapes drawn: the view shows what the physics has
            for collision in link.findall("collision"):
                ET.SubElement(link, "visual").extend(list(collision))
                replaced += 1
    if (mujoco := root.find("mujoco")) is None:
        root.insert(0, mujoco := ET.Element("mujoco"))
    compiler = mujoco.find("compiler") if mujoco.find("compiler") is not None else ET.SubElement(mujoco, "compiler")
    for key in ("strippath", "discardvisual", "fusestatic", "balanceinertia"):
        compiler.attrib.setdefault(key, "false")
    # A link a joint moves with no <inertial> (a gimbal's yoke) is massless in URDF; MuJoCo refuses a moving body
    # under mjMINVAL, so it gets a negligible one (the bounds lift nothing heavier)
    # (one with collision shapes weighs as water, MuJoCo's default for a body with none: said, as URDF says 0)
    carried = {j.find("child").get("link") for j in root.iter("joint") if _moves(j)}
    bare = [k for k in root.iter("link") if k.find("inertial") is None]
    solid = [k.get("name") for k in bare if k.find("collision") is not None]
    if massless := [k.get("name") for k in bare if k.get("name") in carried and k.find("collision") is None]:
        compiler.attrib.setdefault("boundmass", "1e-6")
        compiler.attrib.setdefault("boundinertia", "1e-9")
    if mujoco.find("option") is None:
        ET.SubElement(ET.SubElement(mujoco, "option"), "flag", {"contact": "disable"})
    said = [f"held still {', '.join(held)} (fingers and mimic joints)"] * bool(held)
    if massless:
        said.append(f"no <inertial> on {', '.join(massless)}: given 1e-6 kg (URDF's massless, MuJoCo's minimum)")
    if solid:
        said.append(f"{', '.join(solid)}: no <inertial>, mass from its collision shapes at 1000 kg/m³ (MuJoCo's)")
    if dropped:
        said.append(f"{dropped} visual(s) MuJoCo cannot read dropped, {replaced} collision shape(s) drawn instead")
    return "; ".join(said)


def _moves(joint: ET.Element) -> bool:
    return joint.get("type") in ("revolute", "continuous", "prismatic") and joint.find("child") is not None


def _readable(element: ET.Element) -> bool:
    mesh = element.find("geometry/mesh")
    return mesh is None or Path(mesh.get("filename", "")).suffix.lower() in READABLE_MESHES


def _srdf_beside(source: Path, robot_name: str) -> ET.Element | None:
    """The SRDF named as the file (or its robot) beside it or in a sibling ``srdf`` folder."""
    names = [f"{stem}.srdf" for stem in (source.stem, robot_name)]
    found = [f / n for n in names for f in (source.parent, source.parent.parent / "srdf") if (f / n).is_file()]
    return _parsed(found[0]) if found else None


def _parsed(path: Path) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ConfigError(f"--robot: cannot read {str(path)!r}: {exc}") from None


def _home(srdf: ET.Element | None, joints, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The SRDF's first group state of ``HOME_STATES`` (or its only one), else (and for a joint it leaves
    out) mid-range; ``HOME_MARGIN_RAD`` inside each limit at least."""
    bounded = np.isfinite(lower) & np.isfinite(upper)
    home = np.where(bounded, (np.where(bounded, lower, 0) + np.where(bounded, upper, 0)) / 2, 0.0)
    states = {} if srdf is None else {s.get("name"): s for s in srdf.iter("group_state")}
    named = [states[name] for name in HOME_STATES if name in states] + list(states.values()) * (len(states) == 1)
    values = {j.get("name"): j.get("value", "") for j in named[0].iter("joint")} if named else {}
    for k, joint in enumerate(joints):
        if re.fullmatch(r"\s*-?[\d.]+(e-?\d+)?\s*", values.get(joint, "")):
            home[k] = float(values[joint])
    margin = np.minimum(HOME_MARGIN_RAD, 0.1 * (upper - lower))
    return np.round(np.clip(home, lower + margin, upper - margin), 6)


def _cached(filename: str, text: str) -> Path:
    """``text`` written once as ``filename`` in the user's cache (a read-only home: the temporary folder)."""
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "robot_controller" / "robots"
    for folder in (home, Path(tempfile.gettempdir()) / f"robot_controller-{os.getuid()}"):
        path = folder / filename
        try:
            if not (path.is_file() and path.read_text() == text):
                folder.mkdir(parents=True, exist_ok=True)
                temporary = path.with_suffix(f".{os.getpid()}.tmp")
                temporary.write_text(text)
                temporary.replace(path)  # atomic: processes starting together never read half a file
            return path
        except OSError as exc:
            error = exc
    raise ConfigError(f"--robot: cannot write {filename} to the cache: {error}")


@dataclass(frozen=True)
class Robot:
    """``urdf`` returns its URDF file ("": the reference arm); ``home_position`` (where it starts and the trajectory
    is centred) and the default sine's ``amplitude`` are rad per joint (m on a slide); ``note``: what was changed to
    load its description (fingers held still, meshes dropped)."""

    name: str
    summary: str
    urdf: Callable[[], str]
    home_position: tuple[float, ...]
    amplitude: tuple[float, ...]
    frequency_hz: float
    note: str = ""
    rated_payload_kg: float = 0.0  #: kg, the maker's rated payload (the controller allows for one it does not know)
    #: rad (m on a prismatic joint): how far the true position may be from the reference in force, start included,
    #: for a run to be ``ok`` (``run --tracking-band``)
    tracking_band_rad: float = 0.02

    def layer(self) -> dict[str, dict[str, Any]]:
        if not (urdf := self.urdf()):
            return {}  # the schema's defaults are the reference arm's
        home = list(self.home_position)
        return {
            "simulator": {"urdf_path": urdf, "initial_position": home},
            "motor_node": {"urdf_path": urdf},
            "sensor_node": {"urdf_path": urdf},  # (for its joints' units)
            # Without readings the controller stops on its model open loop, which gravity makes
            # unstable on a chain of joints: the brakes take over after CHAIN_SENSOR_TIMEOUT_S.
            "pid_controller": {"urdf_path": urdf, "design_position": home, "sensor_timeout_s": CHAIN_SENSOR_TIMEOUT_S}
            | ({"rated_payload_kg": self.rated_payload_kg} if self.rated_payload_kg else {}),
            "trajectory_planner": {
                "urdf_path": urdf,
                "joint_count": len(home),
                "mode": "sine",
                "offset": home,
                "amplitude": list(self.amplitude),
                "frequency_hz": self.frequency_hz,
            },
        }


def _shipped(filename: str) -> Callable[[], str]:
    return lambda: str(resources.share_dir() / "description" / filename)


DEFAULT_ROBOT = "one_dof"
DESCRIBED_FREQUENCY_HZ = 0.25  #: of the default sine of an arm known by its description
#: s, how long a chain of joints is stopped on its model alone before the brakes hold it
CHAIN_SENSOR_TIMEOUT_S = 0.2

ROBOTS: dict[str, Robot] = {
    robot.name: robot
    for robot in (
        Robot(
            "one_dof",
            "the tutorial's arm: one revolute joint, a 0.5 m 1 kg link, 10 N·m",
            lambda: "",
            (0.0,),
            (1.0,),
            0.5,
        ),
        Robot(
            "planar2",
            "a two-link planar arm in a vertical plane (description/planar2_arm.urdf), 30 and 10 N·m",
            _shipped("planar2_arm.urdf"),
            (0.0, 0.0),
            (0.6, 0.8),
            0.5,
        ),
        Robot(
            "scara",
            "a small SCARA (description/scara_arm.urdf): two vertical revolute joints, 30 and 10 N·m, "
            "and a vertical prismatic quill, 0.2 m, 40 N",
            _shipped("scara_arm.urdf"),
            (0.0, 0.6, 0.1),
            (0.6, 0.8, 0.05),
            0.5,
        ),
        Robot(
            "panda",
            "the Franka Emika Panda's 7 arm joints (example-robot-data), 87 and 12 N·m; the fingers held still",
            lambda: str(describe("panda").path),
            # The "ready" pose of the Panda's SRDF (example-robot-data's panda.srdf, group state "default").
            (0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398),
            (0.4, 0.3, 0.4, 0.4, 0.5, 0.4, 0.6),
            0.25,
            rated_payload_kg=3.0,  # Franka's datasheet
        ),
    )
}


def robot(name: str) -> Robot:
    """One of ``ROBOTS``, else the arm ``name`` names by its description; a ConfigError if none can run."""
    return ROBOTS[name] if name in ROBOTS else _described(name)


@lru_cache(maxsize=16)
def _described(name: str) -> Robot:
    arm = describe(name, ROBOTS)
    path = str(arm.path)
    return Robot(arm.name, path, lambda: path, arm.home, arm.amplitude, DESCRIBED_FREQUENCY_HZ, arm.note)


def arm_name(name: str, urdf_path: str) -> str:
    """The arm a run drives: robot ``name``'s, or the file's stem where a config file gave another URDF."""
    return robot(name).name if urdf_path == robot(name).urdf() else Path(urdf_path).stem


def urdf_of(name: str) -> Path:
    return resources.resolve_urdf(robot(name).urdf())
