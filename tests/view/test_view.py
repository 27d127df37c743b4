"""The live view (``run --view``): its pieces without ROS, then a real run
with the viewer, looked at in headless Chromium, and the view rebuilt from
the run's bag."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import textwrap
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.controller import state_layout
from robot_controller.core.errors import ConfigError
from robot_controller.view import arm as arm_view
from robot_controller.view import feed, layout
from robot_controller.view import serve as serving
from tests.rostools import run_said

REPO = Path(__file__).resolve().parents[2]
# Where the screenshot of the live run is also copied, if set (how docs/view.png was made).
SCREENSHOT_ENV = "ROBOT_CONTROLLER_VIEW_SCREENSHOT"
TRUE_ORANGE = np.array(layout.POSES["true"][0][:3])


# --- pieces, no ROS ---------------------------------------------------------------------


class FakeRecording:
    """Takes what an Outlet sends: scalars per entity, poses per entity, text lines."""

    def __init__(self) -> None:
        self.columns: dict[str, list] = {}
        self.texts: list[str] = []

    def send_columns(self, path, indexes, columns) -> None:
        self.columns.setdefault(path, []).append((indexes, columns))

    def set_time(self, *args, **kwargs) -> None:
        pass

    def log(self, path, entry) -> None:
        self.texts.append(path)

    def rows(self, path: str) -> int:
        return sum(len(list(c[1])[0].as_arrow_array()) for c in self.columns.get(path, []))


def test_decimator_keeps_at_most_one_sample_per_bucket_and_every_spike():
    t = np.arange(0, 2.0, 0.001)  # 1 kHz for 2 s
    v = np.zeros_like(t)
    v[1234] = 5.0  # a spike
    first = feed.Decimator(50.0)
    extreme = feed.Decimator(50.0, extreme=True)
    out_t, out_e = [], []
    for k in range(0, len(t), 37):  # in uneven pieces, as flushes come
        out_t.append(first.take(t[k : k + 37], v[k : k + 37])[0])
        out_e.append(extreme.take(t[k : k + 37], v[k : k + 37])[1])
    out_t.append(first.take(np.zeros(0), np.zeros(0), final=True)[0])
    out_e.append(extreme.take(np.zeros(0), np.zeros(0), final=True)[1])
    kept = np.concatenate(out_t)
    assert len(kept) == 100  # 50 Hz × 2 s
    assert np.all(np.diff(np.floor(kept * 50)) == 1)  # one per 20 ms bucket, in order
    assert np.max(np.concatenate(out_e)) == 5.0  # the spike survives the thinning


def test_reference_in_force_interpolates_and_skips_idle_ticks():
    ticks = np.array([0.0, 0.01, 0.02, 0.03])
    reference = np.array([[0.0], [1.0], [2.0], [3.0]])
    ok, stopped = state_layout.STATUS_CODES["ok"], state_layout.STATUS_CODES["stopped"]
    status = np.array([ok, ok, stopped, ok])
    got = feed.reference_in_force(ticks, reference, status, np.array([0.005, 0.015, 0.025, -1.0]), 0.01)
    assert got[0, 0] == pytest.approx(0.5)
    assert got[1, 0] == pytest.approx(1.5)
    assert np.isnan(got[2, 0])  # a stopped tick puts no reference in force
    assert np.isnan(got[3, 0])  # before the first tick


def test_feed_thins_the_loop_to_browser_rates_and_stays_bounded():
    arm = arm_view.Arm(resources.default_urdf())
    live, saved = FakeRecording(), FakeRecording()
    view = feed.ViewFeed([feed.Outlet(live, 0.2, 0.1), feed.Outlet(saved, 2.0)], arm, nominal_period_s=0.01)
    width = state_layout.width(1)
    for k in range(1000):  # 10 s of a 100 Hz loop, flushed every 0.1 s
        t = 100.0 + 0.01 * k
        row = state_layout.encode(t, "ok", t - 0.001, 1, {name: np.array([np.sin(t)]) for name in state_layout.FIELDS})
        assert len(row) == width
        view.controller_state(row)
        view.true_state(t, [np.sin(t)], [1.0])
        view.measured(t, [np.sin(t) + 0.001])
        if k % 10 == 9:
            view.flush(0.01 * k)
    view.flush(100.0, final=True)
    for path in (
        "plots/position/true",
        "plots/position/reference",
        "plots/error/error_true",
        "plots/timing/jitter",
        "plots/torque/commanded",
    ):
        assert 0.9 * 500 <= live.rows(path) <= 501, path  # 50 Hz of 100 Hz, over 10 s
        assert live.rows(path) == saved.rows(path), path  # the file gets the same samples
    pose = "world/arm/link1/visual_0"
    assert 0.9 * 200 <= live.rows(pose) <= 201  # 20 Hz
    centers = [list(c[1])[0].as_arrow_array() for c in live.columns[pose]]
    # Each row places the three arms (true, measured, reference) at once.
    assert sum(len(c.flatten()) for c in centers) == 3 * live.rows(pose)
    assert len(saved.columns[pose]) <= 7  # larger chunks for the file: every 2 s
    # A viewer that cannot keep up drops the oldest samples instead of queueing them all.
    for k in range(3 * feed.MAX_PENDING):
        view.measured(200.0 + 0.001 * k, [0.0])
    assert len(view.measured_in) == feed.MAX_PENDING


def test_the_viewer_reads_raw_messages_as_rclpy_wrote_them():
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    from robot_controller.nodes.viewer import decode

    msg = JointState(name=["joint1", "joint2"], position=[0.5, -0.25], velocity=[1.0, 2.0], effort=[3.0, -4.0])
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = 12, 250_000_000, "base"
    got = decode(serialize_message(msg), "sensor_msgs/msg/JointState")
    assert (got.header.stamp.sec, got.header.stamp.nanosec, got.name) == (12, 250_000_000, ["joint1", "joint2"])
    assert (got.position.tolist(), got.effort.tolist()) == ([0.5, -0.25], [3.0, -4.0])
    array = Float64MultiArray(data=[1.0, 2.5, -3.0])
    array.layout.dim = [MultiArrayDimension(label="header", size=3, stride=3)]
    assert decode(serialize_message(array), "std_msgs/msg/Float64MultiArray").data.tolist() == [1.0, 2.5, -3.0]
    assert decode(b"\x00\x01\x00\x00\x01", "sensor_msgs/msg/JointState") is None  # not one: dropped


def test_arm_from_the_reference_urdf_posed_by_mujoco():
    arm = arm_view.Arm(resources.default_urdf())
    assert (arm.joint_names, arm.units, arm.base_xyz) == (["joint1"], ["rad"], (0.0, 0.0, 1.0))
    target, reach = arm.sphere
    assert np.allclose(target, arm.base_xyz) and 0.45 < reach < 0.6  # the link's sweep about its joint
    # q = 0: the link lies along +x from the joint; q = π/2 about −y raises it straight up.
    position, rotation, anchor, axis = arm.poses(np.array([[0.0], [np.pi / 2]]))
    assert np.allclose(position[:, 0], [[0.25, 0.0, 1.0], [0.0, 0.0, 1.25]], atol=1e-9)
    # The cylinder (along its own z) lies along the link: +x at q = 0.
    assert np.allclose(np.abs(rotation[0, 0] @ [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0], atol=1e-6)
    assert np.allclose(anchor[:, 0], [0.0, 0.0, 1.0]) and np.allclose(axis[:, 0], [0.0, -1.0, 0.0])
    columns = dict(arm.pose_columns("world/arm", np.zeros((4, 3, 1))))
    assert list(columns) == ["world/arm/link1/visual_0", "world/arm/hubs/joint1"]
    # Each of the 4 rows places the three arms (true, measured, reference) at once; the hub, the true arm's.
    centers = list(columns["world/arm/link1/visual_0"])[0].as_arrow_array()
    assert (len(centers), len(centers.flatten())) == (4, 12)
    from scipy.spatial.transform import Rotation

    for hub in ([0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]):  # the hub's cylinder turned onto the axis
        turned = Rotation.from_quat(arm_view._z_onto(np.array([hub]))).apply([0.0, 0.0, 1.0])
        assert np.allclose(turned[0], hub)


def test_a_busy_port_is_refused_before_anything_is_written(tmp_path):
    from robot_controller.runner import plan
    from robot_controller.runner.options import RunOptions

    with socket.socket() as busy:
        busy.bind((serving.HOST, 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(ConfigError, match=f"view port {port}"):
            plan.plan(plan.check(cfg.load_stack("default"), RunOptions(view_port=port)), tmp_path / "run")
    assert not (tmp_path / "run").exists()
    with pytest.raises(ConfigError):
        serving.check_port(70000)


def test_plan_adds_the_viewer_as_an_observer(tmp_path):
    from robot_controller.runner import plan
    from robot_controller.runner.options import RunOptions

    options = RunOptions(view_port=serving.free_port())
    run = plan.plan(plan.check(cfg.load_stack("default"), options), tmp_path / "run")
    without = plan.plan(plan.check(cfg.load_stack("default"), RunOptions()), tmp_path / "other")
    for planned in (run, without):
        shutil.rmtree(planned.counts_dir, ignore_errors=True)
    assert run.viewer is not None and run.viewer.module == "viewer"
    assert str(tmp_path / "run" / "view.rrd") in run.viewer.args
    assert run.view_url.startswith("http://127.0.0.1:")
    # It hears the run's partition, as the recorder does.
    assert run.viewer.env["FASTRTPS_DEFAULT_PROFILES_FILE"] == run.recorder.env["FASTRTPS_DEFAULT_PROFILES_FILE"]
    assert all(p.name != "viewer" for p in run.nodes)  # the run does not end if the viewer does
    assert without.viewer is None and without.view_url is None


def _grpc_web_read(port: int, min_bytes: int = 1000) -> tuple[int, bytes]:
    """rerun's ReadMessages over gRPC-web on ``port`` (as the viewer calls it): status, the stream's first bytes."""
    import http.client

    conn = http.client.HTTPConnection(serving.HOST, port, timeout=10)
    try:
        conn.request(
            "POST",
            "/rerun.sdk_comms.v1alpha1.MessageProxyService/ReadMessages",
            body=b"\x00\x00\x00\x00\x00",  # an empty request, framed
            headers={
                "Content-Type": "application/grpc-web+proto",
                "X-Grpc-Web": "1",
                "Origin": "http://localhost:8000",
            },
        )
        reply = conn.getresponse()
        got = b""
        while len(got) < min_bytes and (chunk := reply.read1(65536)):
            got += chunk
        return reply.status, got
    finally:
        conn.close()


def test_the_page_its_files_and_its_data_come_from_one_port():
    """What ``ssh -L PORT:127.0.0.1:PORT`` needs: the page opens on its data at the address the browser used, and
    the viewer's files and its gRPC-web stream come through the same port."""
    import http.client

    import rerun as rr

    rec = serving.open_recording()
    grpc_uri = serving.set_sinks(rec, rrd=None, serve=True, blueprint=None)
    for k in range(200):
        rec.set_time(layout.TIMELINE, duration=0.01 * k)
        rec.log("plots/x", rr.Scalars(float(np.sin(0.1 * k))))
    rec.flush()
    port = serving.free_port()
    gateway = serving.serve_web(grpc_uri, port)
    try:
        conn = http.client.HTTPConnection(serving.HOST, port, timeout=10)
        conn.request("GET", "/", headers={"Host": "localhost:8000"})  # a tunnel's local end
        reply = conn.getresponse()
        reply.read()
        assert reply.status == 302
        location = reply.getheader("Location")
        assert location == "/?url=" + urllib.parse.quote("rerun+http://localhost:8000/proxy", safe="")
        conn.request("GET", location)
        reply = conn.getresponse()
        assert reply.status == 200 and b"Rerun" in reply.read()
        conn.request("GET", "/re_viewer.js")  # the viewer's code, from the web server behind the port
        reply = conn.getresponse()
        assert reply.status == 200 and len(reply.read()) > 100_000
        direct = _grpc_web_read(serving.grpc_port_of(grpc_uri))
        through = _grpc_web_read(port)
        assert through[0] == direct[0] == 200
        assert len(through[1]) >= 1000 and through[1][:1000] == direct[1][:1000]  # the recording, streamed
    finally:
        gateway.shutdown()
        rec.disconnect()


# --- a real run, looked at in a browser -----------------------------------------------------


def _chromium() -> str:
    found = shutil.which("chromium")
    if found is None:
        make = subprocess.run(["make", "-C", str(REPO), "chromium"], capture_output=True, text=True, timeout=900)
        found = shutil.which("chromium")
        if found is None:
            pytest.skip(
                "chromium is not installed and `make chromium` could not install it: "
                + (make.stdout + make.stderr)[-500:]
            )
    return found


def _wait_for_page(url: str, process: subprocess.Popen, lines: list[str], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise AssertionError(f"the run ended before the view answered: {''.join(lines)[-3000:]}")
        try:
            with urllib.request.urlopen(url, timeout=2) as reply:  # follows the redirect to the viewer
                if reply.status == 200 and b"Rerun" in reply.read():
                    return
        except (urllib.error.URLError, ConnectionError, TimeoutError):
            pass
        time.sleep(0.3)
    raise AssertionError(f"{url} did not answer within {timeout_s:g} s")


def _observer_cpus() -> frozenset[int] | None:
    from robot_controller.ros import scheduling

    return scheduling.placement("viewer").cpus


def _looks_like_the_view(png: Path) -> tuple[bool, str]:
    """Many colours (not a blank or loading page) and the true arm's orange (data is drawn)."""
    from PIL import Image

    pixels = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3).astype(int)
    colours = len(np.unique(pixels[:, 0] * 65536 + pixels[:, 1] * 256 + pixels[:, 2]))
    orange = int(np.count_nonzero(np.all(np.abs(pixels - TRUE_ORANGE) < 40, axis=1)))
    return colours > 1000 and orange > 300, f"{colours} colours, {orange} orange pixels"


LAUNCH = textwrap.dedent("""
    import sys
    from pathlib import Path
    from robot_controller import parameters as cfg
    from robot_controller.runner import launcher, plan
    from robot_controller.runner.options import RunOptions
    options = RunOptions(float(sys.argv[2]), view_port=int(sys.argv[3]))
    result = launcher.launch(plan.check(cfg.load_stack("default"), options), Path(sys.argv[1]))
    print("@usage", __import__("json").dumps(result.usage), flush=True)
    sys.exit(result.exit_code)
""")


def _tunnel(target_port: int) -> int:
    """A port that forwards each connection to ``target_port`` and nothing else, as ``ssh -L`` does."""
    listener = socket.create_server((serving.HOST, 0))

    def pump(source: socket.socket, sink: socket.socket) -> None:
        try:
            while data := source.recv(65536):
                sink.sendall(data)
        except OSError:
            pass
        finally:
            for end in (source, sink):
                try:
                    end.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def accept() -> None:
        while True:
            client, _ = listener.accept()
            try:
                upstream = socket.create_connection((serving.HOST, target_port))
            except OSError:  # nothing behind the port (the run is over): this connection fails, as ssh's would
                client.close()
                continue
            threading.Thread(target=pump, args=(client, upstream), daemon=True).start()
            threading.Thread(target=pump, args=(upstream, client), daemon=True).start()

    threading.Thread(target=accept, daemon=True).start()
    return listener.getsockname()[1]


@pytest.mark.ros
@pytest.mark.timeout(400)
def test_live_view_of_a_real_run_in_headless_chromium(tmp_path, ros_domain):
    from tests.view.browser import Browser

    _chromium()
    out = tmp_path / "run"
    port = serving.free_port()
    url = serving.page_url(port)
    # `robot-controller run --view` once the CLI is wired; the launcher's API meanwhile.
    run = subprocess.Popen(
        [sys.executable, "-c", LAUNCH, str(out), "25", str(port)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(run.stdout), daemon=True)
    reader.start()
    try:
        _wait_for_page(url, run, lines, 90)
        shot = tmp_path / "view.png"
        verdict = (False, "no screenshot")
        # Where the observers run (off the loop's CPU, see ros.scheduling), below them in priority: a
        # browser rendering WebGL in software takes all the CPU it gets.
        # Through one forwarded port, as from another machine over `ssh -L`: everything must come through it.
        tunnelled = serving.page_url(_tunnel(port))
        with Browser(
            tunnelled, profile_dir=tmp_path / "chromium", nice=15, cpus=_observer_cpus(), watch_requests=True
        ) as browser:
            deadline = time.monotonic() + 90
            time.sleep(8)  # the page loads, then the run's first seconds come in
            while time.monotonic() < deadline:
                try:
                    browser.screenshot(shot)
                except TimeoutError:  # a page still compiling the viewer on a busy host: ask again
                    verdict = (False, "no screenshot within a minute")
                    continue
                verdict = _looks_like_the_view(shot)
                if verdict[0]:  # also after the run ends: a page keeps what it got, and a slow one still draws
                    break
                time.sleep(2)
            asked = [u for u in browser.requests() if u.startswith(("http:", "https:", "ws:", "wss:"))]
        local = [u for u in asked if urllib.parse.urlsplit(u).hostname in ("127.0.0.1", "localhost", "::1")]
        elsewhere = [u for u in local if not u.startswith(tunnelled + "/")]
        assert local and not elsewhere, f"the page asked this host's other ports: {elsewhere[:5]}"
        if os.environ.get(SCREENSHOT_ENV) and shot.exists():
            shutil.copy(shot, os.environ[SCREENSHOT_ENV])
        assert verdict[0], f"the page does not show the run ({verdict[1]}); see {shot}"
        run.wait(timeout=120)
    finally:
        if run.poll() is None:
            run.terminate()
            run.wait(timeout=30)
        reader.join(timeout=10)
    output = "".join(lines)
    assert run.returncode == 0, run_said(output)
    assert f"[launcher] live view: {url}" in output
    usage = json.loads(output.split("@usage ", 1)[1].splitlines()[0])
    assert "cpu_pct_viewer" in usage and usage["cpu_pct_viewer"] < 50
    rrd = out / "view.rrd"
    assert rrd.stat().st_size > 20_000

    # The view of the same run, rebuilt from its bag.
    from rerun.chunk import RrdReader

    from robot_controller.view.from_bag import build_view_from_bag

    rrd.rename(out / "live.rrd")
    built = build_view_from_bag(out, serving.free_port(), serve=False)
    assert built == rrd and rrd.stat().st_size > 20_000
    for path in (out / "live.rrd", built):
        rows: dict[str, int] = {}
        for chunk in RrdReader(path).stream():
            rows[chunk.entity_path] = rows.get(chunk.entity_path, 0) + chunk.num_rows
        assert rows.get("/plots/position/true", 0) > 200, (path, rows)
        assert rows.get("/world/arm/link1/visual_0", 0) > 100, (path, rows)
        assert rows.get("/plots/timing/jitter", 0) > 200, (path, rows)
