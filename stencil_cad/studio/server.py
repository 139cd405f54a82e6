"""Serving the studio: uvicorn on a free port of 127.0.0.1 by default, the address printed, the browser opened."""

from __future__ import annotations

import ipaddress
import logging
import socket
import threading
import webbrowser
from pathlib import Path

from .workspace import DEFAULT_CAP_BYTES, Workspace, default_workspace

log = logging.getLogger(__name__)


def is_loopback(host: str) -> bool:
    """True when ``host`` is only reachable from this machine (``localhost``, 127.0.0.0/8, ``::1``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host``; port 0 takes a free one."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(64)
    sock.set_inheritable(True)
    return sock


def address(sock: socket.socket, host: str) -> str:
    """The studio's address for a browser."""
    port = sock.getsockname()[1]
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/"


def serve(
    host: str = "127.0.0.1",
    port: int = 0,
    workspace: Path | None = None,
    cap_bytes: int = DEFAULT_CAP_BYTES,
    open_browser: bool = True,
    say: object = print,
) -> None:
    """Run the studio until interrupted.

    Args:
        host: Address to listen on; anything but loopback lets other machines use the studio.
        port: Port; 0 takes a free one.
        workspace: The folder the studio writes in. Defaults to :func:`default_workspace`.
        cap_bytes: Most bytes the workspace may hold; the oldest jobs and uploads go first.
        open_browser: Open the page in the default browser.
        say: Told the lines for the maker (the address, a warning).
    """
    import uvicorn

    from .app import create_app

    ws = Workspace(workspace or default_workspace(), cap_bytes)
    app = create_app(ws)
    sock = bind(host, port)
    url = address(sock, host)
    tell = say if callable(say) else print
    if not is_loopback(host):
        tell(
            f"stencil-cad studio: warning: listening on {host}: anyone who can reach this machine can use the "
            "studio, upload pictures and fill its workspace; use the default 127.0.0.1 unless you mean it"
        )
    tell(f"stencil-cad studio: {url} (workspace {ws.root}; Ctrl-C stops it)")
    if open_browser:
        threading.Timer(0.5, webbrowser.open, args=(url,)).start()
    config = uvicorn.Config(app, log_level="warning", lifespan="off")
    uvicorn.Server(config).run(sockets=[sock])
