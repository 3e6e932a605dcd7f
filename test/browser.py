"""Headless Chromium driven over the DevTools protocol (loopback only): open a page, let it run, screenshot.

`chromium --screenshot` shoots at the load event, long before a WebAssembly app such as Rerun's viewer has
compiled and drawn; here the page gets real time first."""

from __future__ import annotations

import base64
import json
import shutil
import socket
import subprocess
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def screenshot(url: str, out: Path, wait_s: float, size: tuple[int, int] = (1280, 800),
               accept: Callable[[Path], bool] | None = None, patience_s: float = 0.0) -> Path:
    """The page after wait_s seconds; with `accept`, shot again every 2 s for up to patience_s more seconds
    until it accepts one (a loaded host draws late); the last shot is in `out`."""
    from websockets.sync.client import connect

    port = _free_port()
    proc = subprocess.Popen([chromium(), "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                             "--enable-unsafe-swiftshader", f"--remote-debugging-port={port}",
                             "--remote-debugging-address=127.0.0.1", f"--window-size={size[0]},{size[1]}",
                             "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 20.0
        while True:
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=1.0))
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)
        page = next(t for t in tabs if t["type"] == "page")
        with connect(page["webSocketDebuggerUrl"], max_size=100_000_000) as ws:
            calls = 0

            def call(method: str, **params) -> dict:
                nonlocal calls
                calls += 1
                ws.send(json.dumps({"id": calls, "method": method, "params": params}))
                while True:
                    reply = json.loads(ws.recv(timeout=60.0))
                    if reply.get("id") == calls:
                        return reply.get("result", reply)

            call("Page.enable")
            call("Page.navigate", url=url)
            time.sleep(wait_s)
            deadline = time.monotonic() + patience_s
            while True:
                out.write_bytes(base64.b64decode(call("Page.captureScreenshot", format="png")["data"]))
                if accept is None or accept(out) or time.monotonic() > deadline:
                    break
                time.sleep(2.0)
    finally:
        proc.terminate()
        try:
            proc.wait(10.0)
        except subprocess.TimeoutExpired:
            proc.kill()
    return out
