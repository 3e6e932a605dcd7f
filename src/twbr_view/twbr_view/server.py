"""Rerun's web viewer and gRPC proxy, served on this machine only, with Rerun's usage analytics off.

`rr.serve_grpc` listens on every interface and has no bind option; the `rerun` executable of the same
wheel takes `--bind`, so it runs as a child process on 127.0.0.1 and the SDK connects to it over loopback.
Rerun reads its analytics switch from $XDG_CONFIG_HOME/rerun/analytics.json: a directory of ours with it
off is given to the child and to this process before rerun is imported (`prepare`).
"""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import tempfile
import time
from pathlib import Path

BIND = "127.0.0.1"


def config_home() -> Path:
    return Path(os.environ.get("TWBR_RERUN_CONFIG", Path.home() / ".cache" / "twbr" / "rerun-config"))


def prepare() -> dict[str, str]:
    """The environment for rerun (ours and the child's): analytics off, written once."""
    home = config_home()
    settings = home / "rerun" / "analytics.json"
    env = {**os.environ, "XDG_CONFIG_HOME": str(home)}
    if not settings.is_file():
        home.mkdir(parents=True, exist_ok=True)
        subprocess.run([rerun_executable(), "analytics", "disable"], env=env, check=True,
                       capture_output=True, timeout=60)
    os.environ["XDG_CONFIG_HOME"] = str(home)
    return env


def rerun_executable() -> str:
    """The wheel's `rerun` binary itself (`python -m rerun_cli` is a wrapper whose child would outlive it)."""
    import rerun_cli

    return str(Path(rerun_cli.__file__).with_name("rerun"))


def _die_with_parent() -> None:
    """In the child: SIGTERM when the node's process dies, however it dies (Linux prctl PR_SET_PDEATHSIG)."""
    import ctypes
    import signal

    with contextlib.suppress(OSError):
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)


def free_port() -> int:
    with socket.socket() as s:
        s.bind((BIND, 0))
        return s.getsockname()[1]


class ViewerServer:
    """`rerun --serve-web` on loopback: the web viewer at `url`, the SDK's proxy at `grpc_url`."""

    def __init__(self, web_port: int = 0, grpc_port: int = 0, memory_limit: str = "25%") -> None:
        env = prepare()
        self.web_port = web_port or free_port()
        self.grpc_port = grpc_port or free_port()
        self.grpc_url = f"rerun+http://{BIND}:{self.grpc_port}/proxy"
        self.url = f"http://{BIND}:{self.web_port}/?url={self.grpc_url.replace('+', '%2B')}"
        cmd = [rerun_executable(), "--serve-web", "--bind", BIND, "--port", str(self.grpc_port),
               "--web-viewer-port", str(self.web_port), "--server-memory-limit", memory_limit]
        # A session of its own: Ctrl-C on the node's terminal must not kill it before the node's last flush.
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 (lives with the child; not a pipe: nobody reads it)
        self.proc = subprocess.Popen(cmd, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True, preexec_fn=_die_with_parent)
        self._wait_listening()

    def _wait_listening(self, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                self._log.seek(0)
                raise RuntimeError(f"rerun exited: {self._log.read().decode(errors='replace')[-500:]}")
            try:
                with socket.create_connection((BIND, self.web_port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.1)
        raise TimeoutError(f"the Rerun web viewer did not listen on port {self.web_port} within {timeout:g} s")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
