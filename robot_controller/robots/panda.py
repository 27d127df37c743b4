"""The Franka Emika Panda from the ``example-robot-data`` package, made loadable by MuJoCo and
drawable by the view: a copy of its URDF written beside the user's cache (nothing is copied into
this repository) with every ``package://`` path resolved, the .stl collision meshes drawn as the
visual ones (neither MuJoCo nor rerun reads its COLLADA), the two prismatic fingers fixed (the loop
drives the 7 arm joints; the fingers' mass stays in the arm) and MuJoCo told to keep mesh paths.
"""

from __future__ import annotations

import importlib.metadata
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from robot_controller.core.errors import ConfigError

PACKAGE_PREFIX = "package://"
SOURCE = "example-robot-data/robots/panda_description/urdf/panda.urdf"


def _share() -> Path:
    try:
        distribution = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise ConfigError(
            "--robot panda: the example-robot-data package is not installed (pip install example-robot-data)"
        ) from None
    return Path(str(distribution.locate_file("cmeel.prefix/share")))


def _cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "robot_controller" / "robots"


def resolved_urdf_text(share: Path) -> str:
    """The Panda's URDF as MuJoCo and the view load it (see the module's docstring)."""
    source = share / SOURCE
    if not source.is_file():
        raise ConfigError(f"--robot panda: {source} is missing from the example-robot-data package")
    tree = ET.parse(source)
    root = tree.getroot()
    for link in root.iter("link"):
        collisions = link.findall("collision")
        for visual in link.findall("visual"):
            link.remove(visual)
        for collision in collisions:  # the same shape drawn: the view shows what the physics has
            visual = ET.SubElement(link, "visual")
            for child in collision:
                visual.append(child)
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename.startswith(PACKAGE_PREFIX):
            mesh.set("filename", str(share / filename[len(PACKAGE_PREFIX) :]))
    for joint in root.iter("joint"):
        if joint.get("type") == "prismatic":  # the fingers
            joint.set("type", "fixed")
            for tag in ("limit", "dynamics", "mimic"):
                for element in joint.findall(tag):
                    joint.remove(element)
    mujoco = ET.Element("mujoco")
    ET.SubElement(
        mujoco,
        "compiler",
        {"strippath": "false", "discardvisual": "false", "fusestatic": "false", "balanceinertia": "false"},
    )
    root.insert(0, mujoco)
    return ET.tostring(root, encoding="unicode")


def urdf_path() -> Path:
    """The resolved Panda URDF, written once per installed package (rewritten if it differs)."""
    share = _share()
    text = resolved_urdf_text(share)
    try:
        return _written(_cache_dir() / "panda.urdf", text)
    except OSError:  # a read-only home: the system's temporary folder instead
        return _written(Path(tempfile.gettempdir()) / f"robot_controller-{os.getuid()}" / "panda.urdf", text)


def _written(path: Path, text: str) -> Path:
    """``path`` holding ``text``, written only if it does not already."""
    if path.is_file() and path.read_text() == text:
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(f".{os.getpid()}.tmp")
    temporary.write_text(text)
    temporary.replace(path)  # atomic: processes starting together never read half a file
    return path
