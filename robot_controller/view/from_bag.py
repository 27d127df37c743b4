"""The view of a saved run, built from its bag: the same scene, series and layout as the live view (``DIR/view.rrd``),
so any run can be looked at again, including runs recorded without ``--view``; a run with a camera, its images with the
markers found too."""

from __future__ import annotations

import signal
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.view import layout
from robot_controller.view import serve as serving
from robot_controller.view.arm import Arm
from robot_controller.view.feed import Outlet, ViewFeed

if TYPE_CHECKING:
    from robot_controller.scoring.bag_reader import Recording

RRD_NAME = "view.rrd"


def run_setup(run_dir: Path) -> tuple[Path, float]:
    """The run's URDF and control period, from its ``params.yaml`` (the defaults if it has none)."""
    from robot_controller import parameters as cfg

    params = cfg.read_params_file(run_dir / "params.yaml") if (run_dir / "params.yaml").is_file() else {}
    urdf = resources.resolve_urdf(params.get("simulator", {}).get("urdf_path", ""))
    rate = float(params.get("pid_controller", {}).get("control_rate_hz", 100.0))
    return urdf, 1.0 / rate


@dataclass
class SavedRun:
    arm: Arm
    period_s: float
    recording: Recording
    images: list[tuple[float, bytes, str]] = field(default_factory=list)  #: the camera's, with its detections


def detection_images(bag_dir: Path) -> list[tuple[float, bytes, str]]:
    """The camera's images with the markers found (``spec.DETECTIONS``) in the bag: (exposure s, data, format), in
    order of exposure; an image that cannot be decoded is skipped."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    from robot_controller.blocks import spec
    from robot_controller.scoring.bag_reader import stamp_of

    typestore = get_typestore(Stores.ROS2_JAZZY)
    images = []
    with Reader(bag_dir) as reader:
        connections = [c for c in reader.connections if c.topic == spec.DETECTIONS.topic]
        for connection, _, raw in reader.messages(connections=connections) if connections else ():
            try:
                msg = typestore.deserialize_cdr(raw, connection.msgtype)
            except Exception:  # noqa: BLE001 - any undecodable bytes: skipped, as scoring skips them
                continue
            images.append((stamp_of(msg), bytes(msg.data), msg.format))
    return sorted(images, key=lambda image: image[0])


def load_run(run_dir: Path) -> SavedRun:
    """What the view of ``run_dir`` shows (``ValueError``: nothing, or a bag that does not fit the run's URDF)."""
    from robot_controller.scoring.report import read_recording

    urdf, period = run_setup(run_dir)
    recording = read_recording(run_dir / "bag")
    arm = Arm(urdf)
    if len(arm.joint_names) != recording.joint_count:
        raise ValueError(f"{run_dir}: the bag has {recording.joint_count} joint(s), {urdf} {len(arm.joint_names)}")
    return SavedRun(arm, period, recording, detection_images(run_dir / "bag"))


def log_run(rec, run: SavedRun) -> None:
    """The scene, the styles and every series of a saved run, to ``rec``."""
    from robot_controller.core.controller import state_layout

    arm, recording = run.arm, run.recording
    layout.log_styles(rec, arm.joint_names, arm.units)
    layout.log_scene(rec, arm)
    feed = ViewFeed([Outlet(rec, float("inf"))], arm, nominal_period_s=run.period_s, live=False)
    s = recording.state
    header = [s["time_s"], s["status"], s["measurement_stamp_s"]]
    for row in np.column_stack(header + [s[name] for name in state_layout.FIELDS]):
        feed.controller_state(row)
    for t, q, effort in zip(recording.true_time_s, recording.true_position, recording.true_effort, strict=False):
        feed.true_state(t, q, effort)
    for t, q in zip(recording.reading_stamp_s, recording.reading_position, strict=False):
        feed.measured(t, q)
    for t, q in zip(recording.planned_time_s, recording.planned_position, strict=False):
        feed.planned(t, q)
    feed.receipts(recording.receipts)
    for t, jitter in recording.diagnostics:
        feed.diagnostics(t, jitter)
    for t, data, image_format in run.images:
        feed.detections(t, data, image_format)
    feed.flush(final=True)


def build_view_from_bag(run_dir: Path, port: int = serving.DEFAULT_PORT, serve: bool = False) -> Path:
    """Write ``run_dir/view.rrd`` from the run's bag and return its path; if ``serve``, serve it at
    ``http://127.0.0.1:PORT`` until Ctrl-C (or SIGTERM). No bag, a port that cannot be served on (``ConfigError``) or a
    bag with nothing to show (``ValueError``) writes nothing."""
    run_dir = Path(run_dir)
    if not (run_dir / "bag").is_dir():
        raise ConfigError(f"{run_dir}: no bag/ here (not a run directory)")
    if serve:
        serving.check_port(port)
    run = load_run(run_dir)
    out = run_dir / RRD_NAME
    rec = serving.open_recording()
    uri = serving.set_sinks(
        rec, rrd=out, serve=serve, blueprint=layout.blueprint(run.arm, live=False, camera=bool(run.images))
    )
    try:
        log_run(rec, run)
        rec.flush()
        if serve:
            assert uri is not None
            web = serving.serve_web(uri, port)
            print(f"view of {run_dir}: {serving.page_url(port)}  (Ctrl-C to stop; saved as {out})", flush=True)
            _wait_for_interrupt()
            web.shutdown()
    finally:
        rec.disconnect()  # closes the file (with its footer) and the server
    return out


def _wait_for_interrupt() -> None:
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        while not stop.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
