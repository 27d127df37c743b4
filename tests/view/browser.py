"""Headless Chromium driven over the DevTools protocol on a pipe (stdlib only).

``--screenshot`` with ``--virtual-time-budget`` stops on virtual time, which
the WebAssembly compile of rerun's viewer does not advance, so it often
catches the loading screen. Here the page gets real seconds to render, and a
screenshot is taken whenever asked for.
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import time
from pathlib import Path

CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-gpu-sandbox",
    "--no-first-run",
    "--no-default-browser-check",
    "--mute-audio",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--remote-debugging-pipe",
)


MAX_EVENTS = 2000


def chromium_path() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """One headless Chromium showing ``url`` in a ``width`` × ``height`` window."""

    def __init__(
        self,
        url: str,
        *,
        width: int = 1400,
        height: int = 900,
        profile_dir: Path,
        nice: int = 0,
        cpus: frozenset[int] | None = None,
        watch_requests: bool = False,
    ) -> None:
        """``watch_requests``: note every request the page makes (``requests``), from its first."""
        exe = chromium_path()
        if exe is None:
            raise FileNotFoundError("chromium is not installed")
        # Chromium reads DevTools commands on fd 3 and answers on fd 4, NUL-terminated JSON.
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        os.set_inheritable(to_child_r, True)
        os.set_inheritable(from_child_w, True)

        def fds() -> None:  # in the child: the pipe ends where Chromium expects them (and its priority)
            os.dup2(to_child_r, 3)
            os.dup2(from_child_w, 4)
            if nice:  # its session's autogroup too: with autogroup scheduling, the group's nice is what counts
                os.nice(nice)
                try:
                    with open("/proc/self/autogroup", "w") as f:
                        f.write(str(nice))
                except OSError:
                    pass
            if cpus:
                os.sched_setaffinity(0, cpus)

        self.process = subprocess.Popen(
            [
                exe,
                *CHROMIUM_FLAGS,
                f"--window-size={width},{height}",
                f"--user-data-dir={profile_dir}",
                "about:blank" if watch_requests else url,
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=fds,
            close_fds=False,
            start_new_session=True,
        )
        os.close(to_child_r)
        os.close(from_child_w)
        self._buffer = b""
        self.events: list[dict] = []  #: DevTools events seen (console messages once ``console`` is on)
        self._next_id = 0
        self.session = self._attach(url)
        # The page's own size, whatever the window's frame takes.
        self._send(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
            self.session,
        )
        if watch_requests:  # the page opened blank; now with the requests noted
            self._send("Network.enable", session=self.session)
            self._send("Page.navigate", {"url": url}, self.session)

    def _send(
        self, method: str, params: dict | None = None, session: str | None = None, timeout_s: float = 30.0
    ) -> dict:
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._to_child, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout_s
        while True:
            while b"\0" in self._buffer:
                raw, self._buffer = self._buffer.split(b"\0", 1)
                reply = json.loads(raw)
                if (
                    "method" in reply
                    and len(self.events) < MAX_EVENTS
                    and reply.get("params", {}).get("type") != "debug"
                    and (not reply["method"].startswith("Network.") or reply["method"] == "Network.requestWillBeSent")
                ):
                    self.events.append(reply)
                if reply.get("id") == self._next_id:
                    if "error" in reply:
                        raise RuntimeError(f"{method}: {reply['error']}")
                    return reply.get("result", {})
            left_s = deadline - time.monotonic()
            if left_s <= 0 or self.process.poll() is not None:
                raise TimeoutError(f"no answer to {method} from chromium")
            if not select.select([self._from_child], [], [], min(left_s, 1.0))[0]:
                continue  # a busy page: its answer may still come, within the timeout
            chunk = os.read(self._from_child, 1 << 20)
            if not chunk:
                raise EOFError("chromium closed its DevTools pipe")
            self._buffer += chunk

    def _attach(self, url: str) -> str:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            pages = [t for t in self._send("Target.getTargets")["targetInfos"] if t["type"] == "page"]
            if pages:
                return self._send("Target.attachToTarget", {"targetId": pages[0]["targetId"], "flatten": True})[
                    "sessionId"
                ]
            time.sleep(0.2)
        raise TimeoutError(f"chromium opened no page for {url}")

    def console(self) -> None:
        """Collect the page's console messages and exceptions into ``events``."""
        self._send("Runtime.enable", session=self.session)
        self._send("Log.enable", session=self.session)

    def messages(self) -> list[str]:
        """Console messages and exceptions seen so far."""
        out = []
        for event in self.events:
            params = event.get("params", {})
            if event["method"] == "Runtime.consoleAPICalled":
                out.append(
                    f"{params.get('type')}: "
                    + " ".join(str(a.get("value", a.get("description", ""))) for a in params.get("args", []))
                )
            elif event["method"] == "Runtime.exceptionThrown":
                out.append(f"exception: {params.get('exceptionDetails', {}).get('text')}")
            elif event["method"] == "Log.entryAdded":
                entry = params.get("entry", {})
                out.append(f"{entry.get('level')}: {entry.get('text')} {entry.get('url', '')}")
        return out

    def requests(self) -> list[str]:
        """The URLs the page asked for (with ``watch_requests``)."""
        sent = [e for e in self.events if e["method"] == "Network.requestWillBeSent"]
        return [e["params"]["request"]["url"] for e in sent]

    def evaluate(self, expression: str):
        result = self._send("Runtime.evaluate", {"expression": expression, "returnByValue": True}, self.session)
        return result.get("result", {}).get("value")

    def screenshot(self, path: Path) -> Path:
        data = self._send("Page.captureScreenshot", {"format": "png"}, self.session, timeout_s=60)["data"]
        path.write_bytes(base64.b64decode(data))
        return path

    def close(self) -> None:
        try:
            self._send("Browser.close", timeout_s=5)
        except (OSError, RuntimeError, TimeoutError, EOFError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for fd in (self._to_child, self._from_child):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
