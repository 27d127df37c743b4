"""Start the stack's processes by forking the launcher (a "zygote"): it imports rclpy, numpy, scipy and
MuJoCo once (:func:`preload`), before any thread or ROS context, so each child starts in milliseconds."""

from __future__ import annotations

import ctypes
import importlib
import io
import os
import signal
import subprocess
import sys
import time
import traceback
from collections.abc import Callable

import setproctitle

# Every module a child runs: imported once in the launcher before forking.
NODE_MODULES = "simulator motor_node sensor_node pid_controller trajectory_planner all_in_one recorder graph_watch"


def preload() -> None:
    """Import every node module (and through them rclpy, numpy, scipy, MuJoCo) into this process."""
    for name in NODE_MODULES.split():
        importlib.import_module(f"robot_controller.nodes.{name}")


class ForkedProcess:
    """A forked child with the slice of ``subprocess.Popen``'s interface the launcher uses."""

    def __init__(self, pid: int, stdout: io.TextIOBase) -> None:
        self.pid = pid
        self.stdout = stdout
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid == self.pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(f"pid {self.pid}", timeout)
            time.sleep(0.01)
        return self.returncode


def dds_started_here() -> bool:
    """Whether Fast DDS has run in this process (threads named ``dds.…``): a child forked from it would
    inherit its XML profiles and locks held by threads that do not exist in the child."""
    for task in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{task}/comm") as comm:
                if comm.read().startswith("dds."):
                    return True
        except OSError:
            continue
    return False


def fork(
    module: str, argv: list[str], env: dict[str, str], setup: Callable[[], None]
) -> ForkedProcess | subprocess.Popen:
    """Fork a child that runs ``robot_controller.nodes.<module>.main(argv)`` in its own session with ``env``,
    ``setup`` first; its stdout and stderr are the returned ``stdout``. Where forking is not safe
    (:func:`dds_started_here`), a fresh interpreter runs the module instead."""
    if dds_started_here():
        return subprocess.Popen(
            [sys.executable, "-m", *argv],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
            bufsize=1,
            env=env,
            start_new_session=True,
            preexec_fn=setup,
        )
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        code = 1
        try:
            # `ps` and `pgrep -f` see `python -m …` (first: it moves the memory the environment lives in).
            setproctitle.setproctitle(" ".join([sys.executable, "-m", *argv]))
            os.close(read_fd)
            os.setsid()
            os.dup2(write_fd, 1)
            os.dup2(write_fd, 2)
            os.close(write_fd)
            devnull = os.open(os.devnull, os.O_RDONLY)
            os.dup2(devnull, 0)
            # Fresh Python streams: the parent's may have been locked mid-write at the fork.
            sys.stdout = open(1, "w", buffering=1, closefd=False, errors="replace")  # noqa: SIM115 - for its life
            sys.stderr = open(2, "w", buffering=1, closefd=False, errors="replace")  # noqa: SIM115
            for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGCHLD):
                signal.signal(signum, signal.SIG_DFL)
            os.environ.clear()
            os.environ.update(env)
            setup()
            sys.argv = argv
            code = importlib.import_module(f"robot_controller.nodes.{module}").main(argv) or 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException:  # noqa: BLE001 - report anything, then exit: never return into the launcher
            traceback.print_exc()
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(code)
    os.close(write_fd)
    return ForkedProcess(pid, os.fdopen(read_fd, "r", buffering=1, errors="replace"))


def die_with_parent(sig: int = signal.SIGTERM, parent: int | None = None) -> None:
    """Ask the kernel to send this process ``sig`` when the thread that forked it ends (``PR_SET_PDEATHSIG``); if
    that parent (pid ``parent``) has already gone, exit at once: the request came too late to take hold."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, sig)
    except OSError:
        return  # not Linux: the process ends by itself
    if parent is not None and os.getppid() != parent:
        os._exit(1)
