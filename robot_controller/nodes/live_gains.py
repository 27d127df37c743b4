"""A live gain change that never stalls the loop. The controller's parameter services answer on a thread of their
own (:class:`ParameterServices`), where a change is checked, its law designed and its delay margin found in a process
of its own (:class:`Designer`), and handed over (``Controller.set_params``) for the loop to take at the start of
its next tick. Designing a law and finding its margin is small numpy steps for tens of ms per joint (hundreds on the
Panda): on the loop's thread, or on a thread of the node's process holding the interpreter against it, that left
readings unanswered until the drive braked."""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING, Any

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter_service import ParameterService

from robot_controller.blocks.controller import designed_margin
from robot_controller.core.errors import ConfigError
from robot_controller.ros.scheduling import yield_to_the_loop
from robot_controller.runner.forking import die_with_parent

if TYPE_CHECKING:
    from robot_controller.core.controller import ControllerConfig
    from robot_controller.core.model import ArmDynamics

# The services' node: hidden (a leading underscore), under the controller's own name.
SERVICES_NODE = "_parameter_services"
# s; how long the services' thread waits for a request before looking whether the node is stopping.
SERVICES_WAKE_S = 0.2


class _ServicesOf:
    """The node as rclpy's ParameterService sees it, its services made on ``host`` instead: the parameters
    are the node's, and their callbacks run on the host's thread."""

    def __init__(self, node: Node, host: Node) -> None:
        self._node, self._host = node, host

    def get_name(self) -> str:
        return self._node.get_fully_qualified_name()  # the services' names are the node's own: /pid_controller/…

    def create_service(self, *args: Any, **kwargs: Any) -> Any:
        return self._host.create_service(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._node, name)


class ParameterServices:
    """``node``'s parameter services (``ros2 param``'s and ``robot-controller param``'s), served on a thread of
    their own; ``node`` is created with ``start_parameter_services=False``."""

    def __init__(self, node: Node) -> None:
        self.host = Node(
            SERVICES_NODE,
            namespace=node.get_fully_qualified_name(),
            context=node.context,
            start_parameter_services=False,
            enable_rosout=False,
        )
        self._services_of = _ServicesOf(node, self.host)  # held here: ParameterService keeps only a weak reference
        ParameterService(self._services_of)
        self._executor = SingleThreadedExecutor(context=node.context)
        self._executor.add_node(self.host)
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="parameter services", daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        context = self._executor.context
        try:
            while not self._stopping.is_set() and context.ok():
                self._executor.spin_once(timeout_sec=SERVICES_WAKE_S)
        except (ExternalShutdownException, RuntimeError):
            if context.ok() and not self._stopping.is_set():
                raise  # the context shutting down under a wait is a stop, anything else is not

    def stop(self) -> None:
        """No more requests: the thread ends after the one it is answering, the services with it (once)."""
        if self._stopping.is_set():
            return
        self._stopping.set()
        self._thread.join(timeout=2 * SERVICES_WAKE_S)
        self._executor.shutdown(timeout_sec=1.0)
        self.host.destroy_node()


_dynamics: ArmDynamics | None = None  # the worker's arm model: the design's copy, as it was when the node forked it


def _start_worker(dynamics: ArmDynamics | None, node_pid: int) -> None:
    global _dynamics
    _dynamics = dynamics
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C is the node's to act on; the worker ends with it
    yield_to_the_loop()  # forked from the controller, it would share its CPU and its priority
    # A node killed (SIGKILL, the launcher's last resort) never shuts the pool down: the worker would wait on its
    # call queue for ever, an orphan (44 of them were seen on a busy host).
    die_with_parent(signal.SIGKILL, node_pid)


def _load_the_design_libraries() -> None:
    """In the worker, at its start: what a design imports on first use (scipy.linalg: 0.2 s of CPU)."""
    import scipy.linalg  # noqa: F401


def _check(config: ControllerConfig, joint_count: int) -> tuple[int | None, str | None]:
    """In the worker: ``(margin, None)``, or ``(None, the reason)`` for a refused design."""
    try:
        return designed_margin(config, _dynamics, joint_count), None
    except ConfigError as exc:
        return None, str(exc)


class Designer:
    """:func:`designed_margin` on ``dynamics`` (a copy the loop never touches) in one worker process, forked when
    the designer is made: it starts with everything imported and the model built."""

    def __init__(self, dynamics: ArmDynamics | None, joint_count: int) -> None:
        self._dynamics, self._joint_count = dynamics, joint_count
        context = multiprocessing.get_context("fork")
        self._pool = ProcessPoolExecutor(1, context, initializer=_start_worker, initargs=(dynamics, os.getpid()))
        self._pool.submit(_load_the_design_libraries)  # the fork now, and the imports, not at the first change

    def margin(self, config: ControllerConfig) -> int | None:
        """:func:`designed_margin` of ``config``, waited for (the caller's thread lets go of the interpreter)."""
        try:
            margin, refused = self._pool.submit(_check, config, self._joint_count).result()
        except BrokenProcessPool:  # the worker is gone (killed): designed here, as correct, if slower for the loop
            return designed_margin(config, self._dynamics, self._joint_count)
        if refused is not None:
            raise ConfigError(refused)
        return margin

    def stop(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
