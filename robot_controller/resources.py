"""Where the package's data (config, robot description) lives: beside the package in a source checkout or editable
install, under the ament share directory after a colcon build."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path


@lru_cache(maxsize=1)
def share_dir() -> Path:
    beside = Path(__file__).resolve().parent.parent
    if (beside / "config" / "fastdds.xml").is_file():
        return beside
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory("robot_controller"))
    except Exception as exc:  # noqa: BLE001 - any failure means the same thing here
        raise FileNotFoundError("robot_controller's config/ and description/ were not found") from exc


def preset_yaml(name: str) -> Path:
    return share_dir() / "config" / "presets" / f"{name}.yaml"


def default_urdf() -> Path:
    return share_dir() / "description" / "one_dof_arm.urdf"


def resolve_urdf(urdf_path: str) -> Path:
    """``""`` means the package's reference arm."""
    return Path(urdf_path) if urdf_path else default_urdf()


def fastdds_profiles() -> Path:
    return share_dir() / "config" / "fastdds.xml"
