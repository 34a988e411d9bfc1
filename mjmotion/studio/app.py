"""The Studio server: a viser server on this machine, one :class:`~.session.Session` per page."""

from __future__ import annotations

import contextlib
import errno
import io
import socket
import threading
from pathlib import Path
from typing import Any

from ..errors import MjmotionError
from .clips import ClipLibrary

LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")
#: Headless Chromium flags for driving the Studio offline with software WebGL (tests, screenshots).
CHROMIUM_ARGS = (
    "--no-sandbox",
    "--use-gl=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
)


def check_host(host: str) -> None:
    """Refuse a ``--host`` that names no address of this machine; an empty one would listen on every
    network interface."""
    if not host.strip():
        raise MjmotionError("--host '': expected an address to listen on (127.0.0.1: this machine only; 0.0.0.0: every network)")
    try:
        socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as e:
        raise MjmotionError(f"--host {host}: not an address ({getattr(e, 'strerror', None) or e}); expected e.g. 127.0.0.1") from None


def check_port(host: str, port: int) -> None:
    """Refuse a port another program listens on (viser would quietly move to the next one), and a
    host this machine has no address of."""
    check_host(host)
    if port == 0:
        return
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError as e:
            if isinstance(e, socket.gaierror) or e.errno == errno.EADDRNOTAVAIL:
                raise MjmotionError(f"--host {host}: not an address of this machine ({e.strerror or e})") from None
            raise MjmotionError(
                f"--port {port}: cannot listen on {host}:{port} ({e.strerror or e}); is another studio running? choose another --port"
            ) from None


class Studio:
    """A running Studio.

    Args:
        library: the clips every page starts with.
        host, port: where to listen (``port=0``: any free port).
        out_dir: the only folder saving writes into.
        autostart: start the live stream when a page opens (so the scene moves at once).
    """

    def __init__(
        self, library: ClipLibrary, host: str = "127.0.0.1", port: int = 8080, out_dir: str | Path = "studio_output", autostart: bool = True
    ):
        import viser

        check_port(host, port)
        self.library = library
        self.out_dir = Path(out_dir).resolve()
        self.autostart = autostart
        self.sessions: dict[int, Any] = {}
        self._lock = threading.Lock()
        # viser prints a banner and picks another port when this one is taken; we say one line ourselves
        with contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host=host, port=port, label="mjmotion studio", verbose=False)
        if port and self.server.get_port() != port:
            self.stop()
            raise MjmotionError(f"--port {port}: cannot listen on {host}:{port}; choose another --port")
        self.host, self.port = host, self.server.get_port()
        self.server.gui.configure_theme(control_width="large", show_share_button=False)
        self.server.initial_camera.position = (2.6, -3.4, 1.8)
        self.server.initial_camera.look_at = (0.5, 0.0, 0.9)
        self.server.on_client_connect(self._connect)
        self.server.on_client_disconnect(self._disconnect)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}"

    def _connect(self, client: Any) -> None:
        from .session import Session

        s = Session(self, client)
        with self._lock:
            self.sessions[client.client_id] = s
        if self.autostart:
            try:
                s.tabs["Stream"].run()
            except MjmotionError as e:
                s.set_status(f"no stream to start ({e}); pick a tab", error=False)

    def _disconnect(self, client: Any) -> None:
        with self._lock:
            s = self.sessions.pop(client.client_id, None)
        if s is not None:
            s.close()

    def stop(self) -> None:
        """Close every page's threads and the server."""
        with self._lock:
            sessions, self.sessions = list(self.sessions.values()), {}
        for s in sessions:
            s.close()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()
