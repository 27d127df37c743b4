"""A live gain change that never stalls the loop. The controller's parameter services answer on a thread of their
own (:class:`ParameterServices`), where a change is checked, its law designed in the designer's process
(:mod:`.designer`), and handed over (``Controller.set_params``) for the loop to take at the start of its next
tick. Checking a change means designing its law and finding its delay margin, tens of ms on
one joint and hundreds on the Panda: on the loop's thread that left readings unanswered until the drive braked."""

from __future__ import annotations

import threading
from typing import Any

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter_service import ParameterService

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
