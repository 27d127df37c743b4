"""Helpers for the integration tests: a test-side rclpy node on its own context."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node


class RosProbe:
    """An rclpy node spinning in a thread, on the given domain, for one test."""

    def __init__(self, domain: int, name: str = "test_probe") -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - context shut down at the end of the test
            pass

    def collect(self, msg_type, topic: str, qos: int = 50) -> list:
        got: list = []

        def keep(msg) -> None:
            with self.lock:
                got.append((time.monotonic(), msg))

        self.node.create_subscription(msg_type, topic, keep, qos)
        return got

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def wait_for(condition: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.05)
