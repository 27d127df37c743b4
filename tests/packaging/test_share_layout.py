"""The package as colcon would install it on a full ROS 2 machine: the wheel
built from this tree carries the ament share/ layout (package marker,
package.xml, config, description, launch files), and every executable a launch
file starts is one of the package's console scripts. `ros2 launch` itself
cannot be installed here: the launch files are read, not run."""

import ast
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_FILES = sorted((ROOT / "launch").glob("*.launch.py"))


def launched_executables(path: Path) -> set[str]:
    """Every ``executable=`` of a ``Node(...)`` call, and the names in a module-level NODES tuple."""
    tree = ast.parse(path.read_text())
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "Node":
            for keyword in node.keywords:
                if keyword.arg == "executable" and isinstance(keyword.value, ast.Constant):
                    found.add(keyword.value.value)
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "NODES" for t in node.targets):
            found.update(ast.literal_eval(node.value))
    return found


def test_launch_files_start_only_console_scripts():
    scripts = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"])
    started = set()
    for path in LAUNCH_FILES:
        compile(path.read_text(), str(path), "exec")
        assert "def generate_launch_description" in path.read_text(), path.name
        started |= launched_executables(path)
    assert started == {"simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner"}
    assert started <= scripts, started - scripts


def test_wheel_carries_the_ament_share_layout(tmp_path):
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--wheel-dir",
            str(tmp_path),
            str(ROOT),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    (wheel,) = tmp_path.glob("robot_controller-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    share = {n.split(".data/data/", 1)[1] for n in names if ".data/data/" in n}
    expected = {
        "share/ament_index/resource_index/packages/robot_controller",
        "share/robot_controller/package.xml",
        "share/robot_controller/config/fastdds.xml",
        "share/robot_controller/config/presets/tutorial.yaml",
        "share/robot_controller/description/one_dof_arm.urdf",
        *(f"share/robot_controller/launch/{p.name}" for p in LAUNCH_FILES),
    }
    assert expected <= share, expected - share
    assert len(LAUNCH_FILES) == 2
