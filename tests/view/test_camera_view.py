"""The camera's image with its detections in the view: logged as an encoded image at its exposure on the view's
timeline, the layout gaining its 2-D view, read by the viewer from raw CDR and replayed from a bag. No ROS graph."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import rerun as rr
import rerun.blueprint as rrb

from robot_controller import resources
from robot_controller.blocks import spec
from robot_controller.core.controller import state_layout
from robot_controller.view import arm as arm_view
from robot_controller.view import feed, from_bag, layout


class Capture:
    """A recording stream that keeps what is logged to it: (time, path, entry), and the blueprints sent."""

    def __init__(self) -> None:
        self.time: float | None = None
        self.logged: list[tuple[float | None, str, object]] = []
        self.blueprints: list[object] = []

    def set_time(self, timeline, duration) -> None:
        assert timeline == layout.TIMELINE
        self.time = duration

    def log(self, path, entry, static=False) -> None:
        self.logged.append((self.time, path, entry))

    def send_columns(self, path, indexes, columns) -> None:
        pass

    def send_blueprint(self, blueprint, make_active=False, make_default=False) -> None:
        assert make_active and make_default
        self.blueprints.append(blueprint)

    def images(self) -> list[tuple[float, bytes, str]]:
        return [
            (t, entry.blob.as_arrow_array()[0].values.to_numpy().tobytes(), str(entry.media_type.as_arrow_array()[0]))
            for t, path, entry in self.logged
            if path == layout.DETECTIONS and isinstance(entry, rr.EncodedImage)
        ]


def _jpeg(value: int = 128) -> bytes:
    ok, data = cv2.imencode(".jpg", np.full((48, 64, 3), value, np.uint8))
    assert ok
    return data.tobytes()


def _tick(view: feed.ViewFeed, t: float) -> None:
    fields = {name: np.zeros(1) for name in state_layout.FIELDS}
    view.controller_state(state_layout.encode(t, "ok", t, 1, fields))


def _views(container) -> list:
    """Every view of a blueprint's container tree."""
    found = []
    for item in getattr(container, "contents", None) or []:
        found += _views(item) if isinstance(item, rrb.Container) else [item]
    return found


@pytest.fixture(scope="module")
def arm():
    return arm_view.Arm(resources.default_urdf())


def test_images_are_logged_at_their_exposure_once_the_timeline_starts(arm):
    live, saved = Capture(), Capture()
    outlets = [feed.Outlet(live, 0.2, 0.1), feed.Outlet(saved, 2.0)]
    view = feed.ViewFeed(outlets, arm, nominal_period_s=0.01)
    first, second = _jpeg(50), _jpeg(200)
    view.detections(99.9, first, "jpeg")  # before the first tick: waits, it has no place on the timeline yet
    view.flush(0.0)
    assert live.images() == [] and live.blueprints == []
    _tick(view, 100.0)
    view.detections(100.2, second, "jpeg")
    view.detections(100.3, b"", "jpeg")  # nothing to show: dropped
    view.flush(0.1)
    for rec in (live, saved):  # each image, as sent, at exposure − first tick, on every outlet
        assert [(round(t, 6), data, kind) for t, data, kind in rec.images()] == [
            (-0.1, first, "image/jpeg"),
            (0.2, second, "image/jpeg"),
        ]
        assert len(rec.blueprints) == 1  # the layout gains the camera's view with its first image, once
    view.detections(100.4, _jpeg(), "png")
    view.flush(0.2, final=True)
    assert live.images()[-1][2] == "image/png" and len(live.blueprints) == 1


def test_a_viewer_behind_keeps_only_the_newest_images(arm):
    live = Capture()
    view = feed.ViewFeed([feed.Outlet(live)], arm, nominal_period_s=0.01)
    for k in range(3 * feed.MAX_PENDING_IMAGES):
        view.detections(float(k), _jpeg(), "jpeg")
    assert len(view.images_in) == feed.MAX_PENDING_IMAGES
    _tick(view, 0.0)
    view.flush(0.0, final=True)
    times = [t for t, _, _ in live.images()]
    assert times == [float(k) for k in range(2 * feed.MAX_PENDING_IMAGES, 3 * feed.MAX_PENDING_IMAGES)]


def test_a_feed_from_a_bag_keeps_every_image_and_the_layout_it_was_given(arm):
    saved = Capture()
    view = feed.ViewFeed([feed.Outlet(saved, float("inf"))], arm, nominal_period_s=0.01, live=False)
    _tick(view, 10.0)
    for k in range(3 * feed.MAX_PENDING_IMAGES):
        view.detections(10.0 + 0.2 * k, _jpeg(), "jpeg")
    view.flush(final=True)
    assert len(saved.images()) == 3 * feed.MAX_PENDING_IMAGES
    assert saved.blueprints == []  # built with the camera's view already (from_bag knows from the bag)


def test_the_layout_shows_the_camera_only_for_a_run_with_one(arm):
    for live in (True, False):
        plain = _views(layout.blueprint(arm, live=live).root_container)
        with_camera = _views(layout.blueprint(arm, live=live, camera=True).root_container)
        assert not any(isinstance(v, rrb.Spatial2DView) for v in plain)
        (image_view,) = [v for v in with_camera if isinstance(v, rrb.Spatial2DView)]
        assert image_view.origin == layout.DETECTIONS
        assert len(with_camera) == len(plain) + 1  # the rest as it was


def test_a_real_recording_takes_the_image_and_the_new_layout(arm):
    rec = rr.RecordingStream(layout.APPLICATION_ID)
    memory = rec.memory_recording()
    view = feed.ViewFeed([feed.Outlet(rec)], arm, nominal_period_s=0.01)
    _tick(view, 0.0)
    view.detections(0.1, _jpeg(), "jpeg")
    view.flush(0.0, final=True)
    rec.flush()
    assert memory.num_msgs() > 0 and len(memory.drain_as_bytes()) > 1000  # the JPEG's bytes went out


def test_the_viewer_reads_a_compressed_image_as_rclpy_wrote_it():
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import CompressedImage

    from robot_controller.nodes.viewer import Viewer

    data = _jpeg()
    msg = CompressedImage(format="jpeg", data=data)
    msg.header.stamp.sec, msg.header.stamp.nanosec = 12, 500_000_000

    class Heard:
        def __init__(self) -> None:
            self.feed = self
            self.got: list = []

        def detections(self, *args) -> None:
            self.got.append(args)

    heard = Heard()
    Viewer._detections(heard, serialize_message(msg))
    Viewer._detections(heard, b"\x00\x01\x00\x00\x01")  # not one: dropped
    assert heard.got == [(12.5, data, "jpeg")]


def test_the_images_are_read_back_from_a_bag_in_order(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    kind = "sensor_msgs/msg/CompressedImage"
    Image, Header, Time = (
        store.types[kind],
        store.types["std_msgs/msg/Header"],
        store.types["builtin_interfaces/msg/Time"],
    )
    bag = tmp_path / "bag"
    images = {2.0: _jpeg(10), 1.5: _jpeg(20)}  # written out of exposure order
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        detections = writer.add_connection(spec.DETECTIONS.topic, kind, typestore=store)
        other = writer.add_connection("/other/compressed", kind, typestore=store)
        for k, (stamp, data) in enumerate(images.items()):
            header = Header(Time(int(stamp), int(stamp % 1 * 1e9)), "camera")
            raw = store.serialize_cdr(Image(header, "jpeg", np.frombuffer(data, np.uint8)), kind)
            writer.write(detections, 1000 + k, raw)
            writer.write(other, 1000 + k, raw)
        writer.write(detections, 2000, b"\x00\x01")  # undecodable: skipped
    assert from_bag.detection_images(bag) == [(1.5, images[1.5], "jpeg"), (2.0, images[2.0], "jpeg")]
