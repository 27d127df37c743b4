"""The stand-in Franka robot: franka-sim, a third party's server that speaks libfranka's protocol (v10) with MuJoCo
inside, run as a subprocess from a venv of its own (it pins numpy and mujoco below ours; ``make franka-sim`` makes
it), with our own Panda in it: ``--robot panda``'s URDF compiled here, nothing downloaded. A libfranka client
(pylibfranka) then drives the arm the rest of the project simulates, as it would drive the real one.

libfranka's ``Robot`` takes a host and no port, so the server listens on the fixed command port 1337, and on every
interface (franka-sim's single-arm server has no bind option). One stand-in per host, then: a lock file queues this
module's servers, and a foreign process on the port makes the server exit, which the error names.
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import os
import resource
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path
from typing import IO

import mujoco

from robot_controller.hardware.franka_arm import ROTOR_INERTIA_KGM2
from robot_controller.robots.description import describe
from robot_controller.ros import scheduling

HOST = "127.0.0.1"
COMMAND_PORT = 1337  # libfranka's command port: a client cannot pick another
#: kg·m² on every joint (``franka_arm.ROTOR_INERTIA_KGM2``). Without it the server's idle hold, a PD on the joint
#: torques computed explicitly (450 N·m·s/rad on joints 1 and 2 at a 1 ms step), is numerically unstable on the
#: Panda's light links: the held arm chatters at 0.4-2.4 rad/s and drifts once torque control starts.
ARMATURE_KGM2 = ROTOR_INERTIA_KGM2
PROBE_S = 2.0  # one readiness probe's budget: a server that dies while starting is noticed this soon
STOP_GRACE_S = 10.0  # a stop takes well under a second; the server's own shutdown watchdog gives up at 15 s
TAIL_LINES = 3
PR_SET_PDEATHSIG = 1
STAND_IN_RT_PRIORITY = 45  #: over the drive's (40), under the kernel's interrupt threads (50)
STAND_IN_RT_BUDGET_US = 1_000_000  #: µs of CPU a thread of it may run without blocking
STAND_IN_NICENESS = -10  # (the loop's own processes run at 0 unless pinned and raised)
# The server's own entry point (run-franka-sim-server's), with Ctrl+C restored first: a shell that starts a job in
# the background ignores SIGINT for it, its children inherit that, and SIGINT is the server's clean shutdown.
LAUNCH = (
    "import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "sys.argv[0] = 'run-franka-sim-server'; from franka_sim.run_server import main; main()"
)


def _ahead_of_its_clients() -> None:
    """Run in the stand-in's process before it starts. A real robot is a machine of its own: its clock never waits
    for ours. franka-sim's physics keeps wall time by dropping the steps it falls behind on while its state stream
    goes on at 1 kHz, so a stand-in kept from a CPU by its client would feed the client states whose time runs ahead
    of its physics (seen: 15 ms behind for good after one stall, every joint then lagging its reference by that
    much). It runs ahead of ordinary processes where the host lets it (root)."""
    with contextlib.suppress(OSError):
        os.setpriority(os.PRIO_PROCESS, 0, STAND_IN_NICENESS)
    # Real-time, as a robot's controller is (where the host lets it): at nice -10 its state stream ran at 760-950 Hz
    # beside a busy graph, the arm's reported state lagged its physics by up to 20 mrad, and a tool starting beside it
    # cost 20 lost commands; SCHED_FIFO, it holds 1 kHz. A thread of it that ran a second without blocking would be
    # stopped by the kernel (RLIMIT_RTTIME), not starve the host.
    with contextlib.suppress(OSError):
        resource.setrlimit(resource.RLIMIT_RTTIME, (STAND_IN_RT_BUDGET_US, 2 * STAND_IN_RT_BUDGET_US))
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(STAND_IN_RT_PRIORITY))
    # Off the CPU a robot's drive takes (ros.scheduling): sharing it, the two stalled each other into 20 lost
    # commands in 6 of 6 runs; apart, 6 of 6 tracked.
    if (cpus := scheduling.loop_cpus()) is not None:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(0, cpus[1])
    # Gone with the process that started it (a test killed on its timeout, a run ended by SIGKILL): SIGINT, its clean
    # shutdown, when the parent dies. Linux's prctl(PR_SET_PDEATHSIG).
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGINT)


class FrankaServerError(RuntimeError):
    """The stand-in did not start: one line naming what failed, ending with the server's last output."""


def default_venv() -> Path:
    """``$FRANKA_SIM_VENV``, else the checkout's ``build/franka-sim-venv``, where ``make franka-sim`` makes it."""
    if configured := os.environ.get("FRANKA_SIM_VENV"):
        return Path(configured)
    return Path(__file__).resolve().parents[2] / "build" / "franka-sim-venv"


def write_panda_mjcf(directory: str | Path) -> Path:
    """``--robot panda``'s arm as the MJCF franka-sim loads (``$FR3_MJCF``): ``directory/panda.xml``.

    franka-sim finds the arm by the names ending in ``joint1``…``joint7`` and ``link7``, which the Panda's are
    (``panda_…``). It adds gravity compensation on every body, a floor and a light itself, and drives the joints
    through applied torques with actuation off, so no actuator is written. Contacts stay off, as in our own plant, so
    franka-sim's self-collision reflex (it looks for ``<prefix>linkN_collision`` geoms) is off too. The meshes are
    referenced where example-robot-data installed them; only the armature (:data:`ARMATURE_KGM2`) is added.
    """
    spec = mujoco.MjSpec.from_file(str(describe("panda").path))
    for joint in spec.joints:
        joint.armature = ARMATURE_KGM2
    spec.compile()  # to_xml writes a compiled spec only
    path = Path(directory) / "panda.xml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(spec.to_xml())
    return path


class FrankaServer:
    """franka-sim serving ``mjcf`` on 127.0.0.1:1337 for the life of a ``with`` block (or from ``start`` to ``stop``).

    :param mjcf: the arm (:func:`write_panda_mjcf`); :param venv: franka-sim's venv (:func:`default_venv`);
    :param log: where the server's output (stdout and stderr) goes, beside ``mjcf`` unless given; :param flags: more of
    its options, e.g. ``--enforce-comm-constraints``, ``--enforce-motion-limits``; :param wait_s: how long ``start``
    waits for the port's lock and the server to serve, s
    """

    host = HOST
    port = COMMAND_PORT

    def __init__(
        self,
        mjcf: str | Path,
        *,
        venv: str | Path | None = None,
        log: str | Path | None = None,
        flags: tuple[str, ...] = (),
        wait_s: float = 30.0,
    ) -> None:
        self.mjcf = Path(mjcf).resolve()
        self.venv = Path(venv) if venv is not None else default_venv()
        self.log = Path(log) if log is not None else self.mjcf.with_name("franka-sim.log")
        self.flags = tuple(flags)
        self.wait_s = wait_s
        self.process: subprocess.Popen | None = None
        self.startup_s: float | None = None  #: from the launch to the first readiness probe passed
        self.exit_code: int | None = None  #: once stopped: 0 when it shut down on its own, negative when killed
        self._lock: IO | None = None
        self._launched = 0.0  # time.monotonic() at the launch

    @property
    def pid(self) -> int:
        if self.process is None:
            raise FrankaServerError("franka-sim is not running")
        return self.process.pid

    def __enter__(self) -> FrankaServer:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def start(self) -> FrankaServer:
        """Launch the server and return once it serves: a libfranka handshake answered and a robot state streamed."""
        for tool in ("python", "franka-sim-check"):
            if not (self.venv / "bin" / tool).is_file():
                raise FrankaServerError(f"franka-sim's venv {self.venv} has no bin/{tool}: run `make franka-sim`")
        if not self.mjcf.is_file():
            raise FrankaServerError(f"franka-sim's arm {self.mjcf} does not exist")
        deadline = time.monotonic() + self.wait_s
        self._take_port(deadline)
        try:
            self._launch()
            self._await_ready(deadline)
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> int | None:
        """SIGINT, the server's clean shutdown, then SIGKILL past :data:`STOP_GRACE_S`; the exit code (0: clean)."""
        try:
            if self.process is not None:
                if self.process.poll() is None:
                    self.process.send_signal(signal.SIGINT)
                    try:
                        self.process.wait(STOP_GRACE_S)
                    except subprocess.TimeoutExpired:
                        self.process.kill()
                        self.process.wait(5.0)
                self.exit_code = self.process.returncode
                self.process = None
        finally:
            if self._lock is not None:
                self._lock.close()  # closing the file releases its lock
                self._lock = None
        return self.exit_code

    def tail(self, lines: int = TAIL_LINES) -> str:
        """The server's last ``lines`` lines of output, on one line."""
        try:
            text = self.log.read_text(errors="replace")
        except OSError as exc:
            return f"(no output: {exc.strerror})"
        return " | ".join(line.strip() for line in text.strip().splitlines()[-lines:]) or "(no output)"

    def _take_port(self, deadline: float) -> None:
        """Wait for this host's lock on the command port: a second stand-in here would find the port taken."""
        path = Path(tempfile.gettempdir()) / f"franka-sim-{self.port}.lock"
        lock = path.open("a")
        while True:
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
                self._lock = lock
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    lock.close()
                    raise FrankaServerError(
                        f"another stand-in on this host held port {self.port} for {self.wait_s:g} s (lock {path})"
                    ) from None
                time.sleep(0.1)
        # A server of someone else's here would pass the readiness probe for ours, which cannot bind and exits.
        with socket.socket() as probe:
            probe.settimeout(1.0)
            if probe.connect_ex((self.host, self.port)) == 0:
                self.stop()
                raise FrankaServerError(f"{self.host}:{self.port} is already served by a process not started here")

    def _launch(self) -> None:
        env = dict(os.environ, FR3_MJCF=str(self.mjcf))
        env.pop("PYTHONPATH", None)  # their venv is whole; ours (or a ROS install's) on the path would shadow it
        self.log.parent.mkdir(parents=True, exist_ok=True)
        command = [str(self.venv / "bin" / "python"), "-u", "-c", LAUNCH, "--no-gripper", *self.flags]
        # A file, not a pipe: nothing reads the server's output while a client runs, and a full pipe would stall it.
        # Its own session: a Ctrl+C at our terminal reaches us, and we stop it.
        with self.log.open("w") as log:
            self.process = subprocess.Popen(
                command,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
                preexec_fn=_ahead_of_its_clients,
            )
        self._launched = time.monotonic()

    def _await_ready(self, deadline: float) -> None:
        """Probe with franka-sim's own readiness check until it passes, the server exits, or ``deadline``."""
        process = self.process
        if process is None:
            raise FrankaServerError("franka-sim was not launched")
        probe = [str(self.venv / "bin" / "franka-sim-check"), "--host", self.host, "--port", str(self.port)]
        last = "none yet"
        while True:
            if (code := process.poll()) is not None:
                raise self._failure(f"exited with code {code} before serving", last)
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise self._failure(f"did not serve within {self.wait_s:g} s", last)
            budget = min(PROBE_S, remaining)
            done = subprocess.run(
                [*probe, "--timeout", f"{budget:.2f}"], capture_output=True, text=True, timeout=budget + 10.0
            )
            if done.returncode == 0 and process.poll() is None:
                self.startup_s = time.monotonic() - self._launched
                return
            last = (done.stderr.strip() or done.stdout.strip() or f"exit {done.returncode}").splitlines()[-1]

    def _failure(self, what: str, probe: str) -> FrankaServerError:
        return FrankaServerError(
            f"franka-sim on {self.host}:{self.port} {what} (FR3_MJCF={self.mjcf}; last probe: {probe}; "
            f"output in {self.log}): {self.tail()}"
        )


def main(args: list[str] | None = None) -> int:
    """``python -m robot_controller.hardware.franka_server [DIR]``: the stand-in Panda served on 127.0.0.1 until
    Ctrl-C, its communication constraints and motion limits enforced as a real robot's are (its MJCF and log in DIR,
    default ``build/franka-sim``)."""
    import signal
    import sys

    argv = list(sys.argv[1:] if args is None else args)
    directory = Path(argv[0] if argv else "build/franka-sim")
    flags = ("--enforce-comm-constraints", "--enforce-motion-limits")
    try:
        with FrankaServer(write_panda_mjcf(directory), flags=flags) as server:
            print(f"franka-sim: the Panda served at franka://{server.host} (log: {server.log}); Ctrl-C stops it")
            stops = {signal.SIGINT, signal.SIGTERM}
            signal.pthread_sigmask(signal.SIG_BLOCK, stops)  # (after the server started: it keeps its own mask)
            signal.sigwait(stops)
    except FrankaServerError as exc:
        print(f"franka-sim: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
