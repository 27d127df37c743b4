"""The process skeleton every node runs in: init with our own signal handling, one executor for one
node or many, spin until Ctrl-C or shutdown, then an orderly cleanup that cannot hang."""

from __future__ import annotations

import faulthandler
import gc
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from robot_controller.core.errors import ConfigError

# The controller ended itself after its control law failed and the arm was stopped and braked.
LAW_STOPPED_EXIT_CODE = 3
# Where in the run's scratch folder (COUNTS_DIR_ENV) the controller writes the law's fault, one line.
LAW_FAULT_FILE = "law_fault.txt"
#: a robot's fault, or its drive's death (``nodes.robot_node``): the run's failure line
ROBOT_FAULT_FILE = "robot_fault.txt"
#: the robot's timing over a run (``hardware.robot_timing``'s figures, JSON)
ROBOT_TIMING_FILE = "robot_timing.json"
#: A paced world's figures (host freezes, late efforts), written by the simulator at its end for metrics.json.
WORLD_CLOCK_FILE = "simulator.world_clock"
#: The controller's missed cycles the host caused (wall clock), written at its end for metrics.json.
HOST_MISSED_FILE = "pid_controller.host_missed"


_exit_code: list[int] = []


def request_exit(code: int) -> None:
    """End the process after the current callback with ``code``, cleaned up as after Ctrl-C."""
    _exit_code.append(code)
    _stop_requested.set()


# Cleanup that takes longer is stuck (rclpy's destroy_node can wait forever after an external shutdown): exit.
CLEANUP_TIMEOUT_S = 5.0
# The DDS teardown, once the node's work is done, takes well under this.
TEARDOWN_TIMEOUT_S = 2.0
# A process whose teardown hung after its work was done ends by this signal (a warning, not a failed run).
TEARDOWN_HUNG_SIGNAL = signal.SIGALRM


def exit_after_cleanup_timeout(code_ref: list[int]) -> threading.Timer:
    """Arm a timer that hard-exits the process if cleanup hangs; cancel it when done."""
    timer = threading.Timer(CLEANUP_TIMEOUT_S, lambda: os._exit(code_ref[0]))
    timer.daemon = True
    timer.start()
    # The timer needs the GIL; faulthandler's watchdog (a C thread) does not: it prints the stacks, exits 1.
    faulthandler.dump_traceback_later(CLEANUP_TIMEOUT_S + 1.0, exit=True)
    return timer


def work_done_teardown_left() -> None:
    """The node's work is done: a hang from here on (the DDS teardown, holding the GIL) prints where it is
    stuck, then ends the process by ``TEARDOWN_HUNG_SIGNAL`` (delivered whoever holds the GIL)."""
    faulthandler.cancel_dump_traceback_later()
    faulthandler.dump_traceback_later(TEARDOWN_TIMEOUT_S, exit=False)
    signal.signal(TEARDOWN_HUNG_SIGNAL, signal.SIG_DFL)
    signal.setitimer(signal.ITIMER_REAL, TEARDOWN_TIMEOUT_S + 0.5)


def shutting_down(within_s: float = 0.5) -> bool:
    """Whether the context is shut down within ``within_s`` (the signal's shutdown lags the error it caused)."""
    deadline = time.monotonic() + within_s
    while rclpy.ok():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def make_executor(context: rclpy.Context | None = None, serves_actions: bool = False) -> Executor:
    """rclpy's EventsExecutor (no wait set rebuilt per callback); ``ROBOT_CONTROLLER_EXECUTOR=single``: the single.
    ``serves_actions``: the single, since Jazzy's EventsExecutor never hands an action server its goals."""
    if not serves_actions and os.environ.get("ROBOT_CONTROLLER_EXECUTOR", "events") == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


_stop_requested = threading.Event()


def stop_requested() -> bool:
    """Whether this process was asked to stop (SIGINT, SIGTERM, ``request_exit``): the run is ending."""
    return _stop_requested.is_set()


def init_with_own_signals(
    args: list[str] | None = None, context: rclpy.Context | None = None, stop: threading.Event = _stop_requested
) -> None:
    """rclpy.init, SIGINT/SIGTERM only setting ``stop``: the spin ends between callbacks, cleanup runs in order.
    ``stop`` is set from a thread: set() in the handler deadlocks on the lock of a ``stop.wait`` it interrupts."""
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: threading.Thread(target=stop.set, daemon=True).start())


def own_context() -> tuple[rclpy.Context, threading.Event]:
    """An observer's (recorder, graph watch) own context, its SIGINT and SIGTERM setting the event returned."""
    context, stop = rclpy.Context(), threading.Event()
    init_with_own_signals(context=context, stop=stop)
    return context, stop


# How long a spin waits for work at most: a signal's Python handler runs only once the main thread is back from the
# wait, and the simulator's drive timeout (50 ms) must not fire at a run's end before it knows the run is ending.
SPIN_WAKE_S = 0.02


def spin(executor: Executor) -> None:
    """Spin until a stop signal or shutdown (spin_once: the EventsExecutor's spin() never returns after one)."""
    # The executor's context, looked up once: rclpy.ok() looks it up on every call, once per message.
    context = executor.context
    stop_requested, spin_once = _stop_requested.is_set, executor.spin_once
    while not stop_requested() and context.ok():
        spin_once(timeout_sec=SPIN_WAKE_S)


def run(node_factories: Callable[[], Node] | list[Callable[[], Node]], args: list[str] | None = None) -> int:
    """Init, build the node(s) on one executor, spin until Ctrl-C or shutdown, clean up; the exit code."""
    factories = node_factories if isinstance(node_factories, list) else [node_factories]
    init_with_own_signals(args)
    nodes: list[Node] = []
    code = [0]
    serves_actions = [getattr(factory, "serves_actions", False) for factory in factories]
    executor = make_executor(serves_actions=all(serves_actions))
    # Several nodes in one process (all_in_one): those serving actions spin on an executor of their own, on a thread,
    # so the loop's nodes keep the EventsExecutor.
    action_executor = make_executor(serves_actions=True) if any(serves_actions) and not all(serves_actions) else None
    try:
        for factory, own in zip(factories, serves_actions, strict=True):
            nodes.append(factory())
            (action_executor if own and action_executor is not None else executor).add_node(nodes[-1])
        if action_executor is not None:
            threading.Thread(target=spin, args=(action_executor,), name="action nodes", daemon=True).start()
        # Everything built so far lives as long as the nodes: out of every later full collection (a pause).
        gc.freeze()
        spin(executor)
        if _exit_code:
            code[0] = _exit_code[0]
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # A signal can shut the context down while a callback takes a message: a normal stop, nothing else is.
        if not shutting_down():
            raise
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        code[0] = 2
    finally:
        guard = exit_after_cleanup_timeout(code)
        if action_executor is not None:
            action_executor.shutdown(timeout_sec=1.0)
        executor.shutdown(timeout_sec=1.0)
        # The stack's nodes (``ros.adapter``; a plain rclpy node has no last words or gates).
        stack_nodes = [node for node in nodes if hasattr(node, "write_publish_counts")]
        for node in stack_nodes:
            node.finish()
        for node in stack_nodes:
            node.wait_until_acknowledged()
            node.write_publish_counts()  # final: nothing publishes now
        work_done_teardown_left()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        guard.cancel()
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        faulthandler.cancel_dump_traceback_later()
    return code[0]
