"""Serving a view to a browser from this machine, offline, on one port (``127.0.0.1:PORT``): behind it, rerun's
gRPC server (holds the recording up to ``SERVER_MEMORY_LIMIT``, the oldest data going past it) and rerun's web server
with the viewer's files, each on a free port picked at start (runs side by side do not collide) and reached only
through the port's gateway. The gateway sends the viewer's gRPC-web calls to the gRPC server and every other request
to the web server, and opens the page with the data's address on its own port, as the browser named it: so one
``ssh -L PORT:127.0.0.1:PORT host`` (or any local port) shows a remote run."""

from __future__ import annotations

import http.client
import socket
import threading
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from robot_controller.core.errors import ConfigError

HOST = "127.0.0.1"
DEFAULT_PORT = 9090
SERVER_MEMORY_LIMIT = "256MiB"
UPSTREAM_CONNECT_TIMEOUT_S = 10.0  # the servers behind the port are on this host: they answer at once or not at all


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def check_port(port: int) -> None:
    """``ConfigError`` if this process cannot serve on ``port`` (in use, out of range)."""
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
    """Send ``rec`` to the file ``rrd`` (if any) and, if ``serve``, a local gRPC server, whose ``rerun+http://…/proxy``
    address is returned (``newest_first``: a browser that connects late gets the present first, then the past)."""
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


#: The gRPC-web calls' paths (rerun's services: ``/rerun.<package>.<Service>/<Method>``).
GRPC_PATH_PREFIX = "/rerun."
#: Headers about one hop of a connection, never passed on.
HOP_BY_HOP = {"connection", "keep-alive", "proxy-connection", "te", "trailer", "transfer-encoding", "upgrade"}
COPY_CHUNK = 64 * 1024


class _Gateway(BaseHTTPRequestHandler):
    """One port for the page, its files and its data: ``/`` with no ``url`` opens the viewer on this port's data;
    gRPC-web calls go to the gRPC server, the rest to the web server; replies are streamed as they come."""

    protocol_version = "HTTP/1.1"  # keep-alive, and chunked replies for the data's endless stream

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        path, _, query = self.path.partition("?")
        if path in ("", "/", "/index.html") and "url" not in urllib.parse.parse_qs(query):
            host = self.headers.get("Host") or f"{HOST}:{self.server.server_address[1]}"  # as the browser named it
            self.send_response(302)
            self.send_header("Location", f"/?url={urllib.parse.quote(f'rerun+http://{host}/proxy', safe='')}")
            self.send_header("Cache-Control", "no-store")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return
        self._forward(self.server.web_port)

    def do_HEAD(self) -> None:  # noqa: N802
        self.do_GET()

    def do_POST(self) -> None:  # noqa: N802
        grpc = self.path.startswith(GRPC_PATH_PREFIX)
        self._forward(self.server.grpc_port if grpc else self.server.web_port)

    def do_OPTIONS(self) -> None:  # noqa: N802
        self.do_POST()

    def _forward(self, port: int) -> None:
        length = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(length) if length else None
        # The browser's Origin is this port's; the servers behind see a request of their own host's.
        skip = HOP_BY_HOP | {"host", "origin", "content-length"}
        headers = {k: v for k, v in self.headers.items() if k.lower() not in skip}
        upstream = http.client.HTTPConnection(HOST, port, timeout=UPSTREAM_CONNECT_TIMEOUT_S)
        try:
            upstream.request(self.command, self.path, body=body, headers=headers)
            upstream.sock.settimeout(None)  # the data's stream stays open as long as the page does
            reply = upstream.getresponse()
        except OSError as exc:
            upstream.close()
            self.send_error(502, f"the view's server on port {port} did not answer ({exc})")
            return
        try:
            self._relay(reply)
        except (BrokenPipeError, ConnectionResetError):
            self.close_connection = True  # the page went away
        finally:
            upstream.close()

    def _relay(self, reply: http.client.HTTPResponse) -> None:
        self.send_response_only(reply.status, reply.reason)
        length = reply.getheader("Content-Length")
        for key, value in reply.getheaders():
            if key.lower() not in HOP_BY_HOP:
                self.send_header(key, value)
        bodiless = self.command == "HEAD" or reply.status in (204, 304) or 100 <= reply.status < 200
        chunked = length is None and not bodiless
        if chunked:
            self.send_header("Transfer-Encoding", "chunked")
        self.end_headers()
        if bodiless:
            return
        while chunk := reply.read1(COPY_CHUNK):
            self.wfile.write(b"%x\r\n%s\r\n" % (len(chunk), chunk) if chunked else chunk)
            self.wfile.flush()
        if chunked:
            self.wfile.write(b"0\r\n\r\n")
            self.wfile.flush()

    def log_message(self, *args) -> None:  # quiet: the launcher's output is for the run
        pass


class Gateway(ThreadingHTTPServer):
    """The view's one port: ``shutdown()`` stops it."""

    daemon_threads = True

    def __init__(self, port: int, web_port: int, grpc_port: int) -> None:
        super().__init__((HOST, port), _Gateway)
        self.web_port, self.grpc_port = web_port, grpc_port


def serve_web(grpc_uri: str, port: int) -> Gateway:
    """rerun's web viewer on a free port, and on ``port`` the gateway to it and to the gRPC server at ``grpc_uri``
    (``rerun+http://127.0.0.1:N/proxy``), served by a daemon thread."""
    import rerun as rr

    web_port = free_port()
    rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=grpc_uri)
    server = Gateway(port, web_port, grpc_port_of(grpc_uri))
    threading.Thread(target=server.serve_forever, name="view-gateway", daemon=True).start()
    return server


def grpc_port_of(grpc_uri: str) -> int:
    """The port of a ``rerun+http://host:port/proxy`` address."""
    port = urllib.parse.urlsplit(grpc_uri.removeprefix("rerun+")).port
    if port is None:
        raise ValueError(f"no port in the gRPC server's address {grpc_uri!r}")
    return port
