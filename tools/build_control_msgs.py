"""Build control_msgs (interfaces/control_msgs) into this Python's prefix, once.

control_msgs has no PyPI wheel: it is generated with the ROS 2 Jazzy wheels'
own rosidl_generate_interfaces through CMake, as colcon would. Skipped when a
sourced ROS 2 (AMENT_PREFIX_PATH) has control_msgs, or when this prefix holds a
build of the same interface files. Fails with one line naming what is missing.

Usage: .venv/bin/python tools/build_control_msgs.py
"""

import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

SOURCE = Path(__file__).resolve().parents[1] / "interfaces" / "control_msgs"
PREFIX = Path(sys.prefix)
BUILD = PREFIX / "build" / "control_msgs"
DIGEST = BUILD / "source.sha256"
LOG = BUILD / "build.log"
# The wheels' exported CMake targets name the wheel builder's Python and numpy headers.
BUILDER_NUMPY = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/_core/include")
BUILDER_PYTHON = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")


class Missing(RuntimeError):
    """What the build lacks, in one line."""


def sourced_control_msgs() -> Path | None:
    """The prefix of a sourced ROS 2 that has control_msgs, if any (this prefix excluded)."""
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        found = entry and (Path(entry) / "share" / "control_msgs" / "package.xml").is_file()
        if found and Path(entry).resolve() != PREFIX.resolve():
            return Path(entry)
    return None


def source_digest() -> str:
    """sha256 over the interface files, so that an edit to one of them rebuilds."""
    digest = hashlib.sha256()
    for path in sorted(p for p in SOURCE.rglob("*") if p.is_file()):
        digest.update(path.relative_to(SOURCE).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def installed(digest: str) -> bool:
    site = Path(sysconfig.get_paths()["purelib"])
    return (
        DIGEST.is_file()
        and DIGEST.read_text().strip() == digest
        and (PREFIX / "share" / "control_msgs" / "package.xml").is_file()
        and (site / "control_msgs" / "action" / "__init__.py").is_file()
    )


def check_tools() -> None:
    for names, what in ((["cmake"], "cmake"), (["cc", "gcc"], "a C compiler"), (["c++", "g++"], "a C++ compiler")):
        if not any(shutil.which(name) for name in names):
            raise Missing(f"{what} not found on PATH (apt-get install cmake g++), or source a ROS 2 with control_msgs")
    headers = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not headers.is_file():
        raise Missing(f"Python headers not found ({headers}): install python3-dev")


def run(step: str, command: list[str]) -> None:
    """Run one step, its output appended to the log; on failure, the step and the log's first error."""
    with LOG.open("a") as log:
        log.write(f"\n$ {' '.join(command)}\n")
        log.flush()
        code = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT).returncode
    if code != 0:
        lines = [ln.strip() for ln in LOG.read_text(errors="replace").splitlines() if ln.strip()]
        errors = [ln for ln in lines if re.search("error|could not", ln, re.IGNORECASE)]
        telling = [ln for ln in errors if not ln.startswith("CMake Error at") and "error code" not in ln]
        raise Missing(f"{step} failed (log: {LOG}): {(telling or errors or lines or [''])[0]}")


def localise_include_paths() -> int:
    """Point the wheels' exported CMake files at this machine's Python and numpy headers; the count rewritten."""
    import numpy

    python_include = sysconfig.get_paths()["include"]
    rewritten = 0
    for path in (PREFIX / "share").glob("*/cmake/*.cmake"):
        text = path.read_text()
        if "/opt/python/" not in text:
            continue
        local = BUILDER_PYTHON.sub(python_include, BUILDER_NUMPY.sub(numpy.get_include(), text))
        if local != text:
            path.write_text(local)
            rewritten += 1
    return rewritten


def build(digest: str) -> None:
    check_tools()
    BUILD.mkdir(parents=True, exist_ok=True)
    LOG.write_text("")
    requirements = SOURCE / "build-requirements.txt"
    run("pip install -r " + str(requirements), [sys.executable, "-m", "pip", "install", "-q", "-r", str(requirements)])
    localise_include_paths()
    configure = [
        "cmake", "-S", str(SOURCE), "-B", str(BUILD / "cmake"), "-DBUILD_TESTING=OFF",
        f"-DCMAKE_INSTALL_PREFIX={PREFIX}", f"-DCMAKE_PREFIX_PATH={PREFIX}", f"-DPython3_EXECUTABLE={sys.executable}",
    ]  # fmt: skip
    run("cmake configure", configure)
    run("cmake build", ["cmake", "--build", str(BUILD / "cmake"), "-j", str(os.cpu_count() or 1)])
    run("cmake install", ["cmake", "--install", str(BUILD / "cmake")])
    run("import check", [sys.executable, "-c", "from control_msgs.action import FollowJointTrajectory"])
    DIGEST.write_text(digest + "\n")


def main() -> int:
    sourced = sourced_control_msgs()
    if sourced is not None:
        print(f"control_msgs: the sourced ROS 2's, in {sourced}")
        return 0
    digest = source_digest()
    if installed(digest):
        return 0
    print(f"control_msgs: building into {PREFIX} (about a minute, once)", flush=True)
    try:
        build(digest)
    except Missing as missing:
        print(f"control_msgs: {missing}", file=sys.stderr)
        return 1
    print("control_msgs: built")
    return 0


if __name__ == "__main__":
    sys.exit(main())
