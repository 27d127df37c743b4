"""Serving a view to a browser from this machine, offline, from three local servers: rerun's gRPC server (holds the
recording up to ``SERVER_MEMORY_LIMIT``, the oldest data going past it), rerun's web server with the viewer's files, and
on the user's port (127.0.0.1) a redirect to the viewer with the gRPC address in its ``?url=``. The gRPC and web ports
are free ones picked at start, so runs side by side do not collide."""

from __future__ import annotations

import socket
import threading
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from robot_controller.core.errors import ConfigError

HOST = "127.0.0.1"
DEFAULT_PORT = 9090
SERVER_MEMORY_LIMIT = "256MiB"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def check_port(port: int) -> None:
    """:raises ConfigError: ``port`` is not a port this process can serve on (in use, out of range)."""
    if not 1 <= port <= 65535:
        raise ConfigError(f"view port {port}: must be 1–65535")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((HOST, port))
        except OSError as exc:
            raise ConfigError(
                f"view port {port}: cannot serve on {HOST}:{port} ({exc.strerror}); choose another port"
            ) from None


def page_url(port: int) -> str:
    return f"http://{HOST}:{port}"


def open_recording(recording_id: str | None = None):
    import rerun as rr

    from robot_controller.view.layout import APPLICATION_ID

    return rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)


def set_sinks(
    rec, *, rrd: Path | None, serve: bool, blueprint, write_footer: bool = True, newest_first: bool = False
) -> str | None:
    """Send ``rec`` to a file and a local gRPC server; the server's ``rerun+http://…/proxy`` address.

    :param rrd: the file (None: none)
    :param serve: whether to serve it (None is returned if not)
    :param newest_first: a browser that connects late gets the present first, then the past
    """
    import rerun as rr

    sinks, uri = [], None
    if serve:
        limit = SERVER_MEMORY_LIMIT
        server = rr.GrpcServerSink(bind_ip=HOST, port=free_port(), server_memory_limit=limit, newest_first=newest_first)
        uri = server.uri
        sinks.append(server)
    if rrd is not None:
        sinks.append(rr.FileSink(rrd, write_footer=write_footer))
    rec.set_sinks(*sinks, default_blueprint=blueprint)
    return uri


class _Redirect(BaseHTTPRequestHandler):
    """Every request sent on to the server's ``target``."""

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        self.send_response(302)
        self.send_header("Location", self.server.target)
        self.send_header("Cache-Control", "no-store")
        self.end_headers()

    do_HEAD = do_GET

    def log_message(self, *args) -> None:  # quiet: the launcher's output is for the run
        pass


def serve_web(grpc_uri: str, port: int) -> ThreadingHTTPServer:
    """rerun's web viewer on a free port, and on ``port`` a redirect to it with ``grpc_uri`` to connect to:
    the redirecting server, served by a daemon thread (``shutdown()`` stops it)."""
    import rerun as rr

    web_port = free_port()
    rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=grpc_uri)
    server = ThreadingHTTPServer((HOST, port), _Redirect)
    server.target = f"http://{HOST}:{web_port}/?url={urllib.parse.quote(grpc_uri, safe='')}"
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, name="view-redirect", daemon=True).start()
    return server
