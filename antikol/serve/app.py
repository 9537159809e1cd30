"""The live view's web server: a small read-only ASGI app (starlette, run by uvicorn).

Routes (GET only; anything else is refused):

* ``/`` — the page (:func:`antikol.serve.page.live_page`);
* ``/events`` — server-sent events: a ``snapshot`` event per analysis cycle (the JSON of
  :meth:`antikol.serve.live.LiveView.snapshot`; the latest one first), ``end`` when a
  replay has ended, a comment every ``heartbeat_s`` to keep connections open;
* ``/snapshot`` — the latest snapshot as JSON (``null`` before the first cycle);
* ``/health`` — ``{"ok": true, "cycles": ..., "viewers": ...}``.

Access: bound to a loopback address the server needs no token; bound to any other address
it needs one (:func:`check_access`) and every request must carry it, as ``?token=`` or an
``Authorization: Bearer`` header (the page passes its own on to ``/events``). Pages are
sent with a content security policy that allows no request but to this server (and to the
tile server, when online tiles were asked for).
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import json
import logging
import secrets
import socket
import threading
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

from antikol.errors import InvalidArgumentError
from antikol.serve.live import LiveView

__all__ = ["ServerThread", "check_access", "create_app", "is_loopback", "require_serve", "run"]

logger = logging.getLogger(__name__)


def require_serve() -> None:
    """Check that the web server's packages are installed.

    Raises
    ------
    trackmap.errors.MissingDependencyError
        starlette or uvicorn is missing (an ``ImportError``); the message says how to
        install them (``pip install 'antikol[serve]'``).
    """
    import importlib

    from trackmap.errors import MissingDependencyError

    for name in ("starlette", "uvicorn"):
        try:
            importlib.import_module(name)
        except ImportError as exc:
            raise MissingDependencyError(
                f"antikol serve needs {name}, which is not installed: pip install "
                "'antikol[serve]' (or pip install starlette uvicorn)"
            ) from exc


def is_loopback(host: str) -> bool:
    """Whether ``host`` is a loopback address (or ``localhost``).

    >>> is_loopback("127.0.0.1"), is_loopback("::1"), is_loopback("0.0.0.0")
    (True, True, False)
    """
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def check_access(host: str, token: str | None) -> str | None:
    """The token the server will require when bound to ``host``.

    Parameters
    ----------
    host : str
        The address the server binds.
    token : str or None
        The token asked for (None: a random one is made when one is needed).

    Returns
    -------
    str or None
        None on a loopback address without a token asked for; otherwise the token.

    Raises
    ------
    InvalidArgumentError
        The token asked for is shorter than 12 characters.
    """
    if token is not None:
        if len(token) < 12:
            raise InvalidArgumentError("token", "*" * len(token), "at least 12 characters")
        return token
    if is_loopback(host):
        return None
    return secrets.token_urlsafe(18)


def _csp(tiles_online: bool) -> str:
    img = "data: https:" if tiles_online else "data:"
    return (
        "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
        f"img-src {img}; connect-src 'self'; font-src data:; base-uri 'none'; "
        "form-action 'none'; frame-ancestors 'none'"
    )


def create_app(
    view: LiveView,
    page: str,
    *,
    token: str | None = None,
    feed: Callable[[], Awaitable[None]] | None = None,
    tiles_online: bool = False,
    heartbeat_s: float = 15.0,
) -> Any:
    """The ASGI app of the live view.

    Parameters
    ----------
    view : LiveView
        The state the app publishes.
    page : str
        The HTML of ``/`` (:func:`antikol.serve.page.live_page`).
    token : str, optional
        Required on every request when given (see :func:`check_access`).
    feed : callable, optional
        Started as a task when the app starts (e.g. a :mod:`~antikol.serve.feeds`
        coroutine), cancelled when it stops; an error in it is logged.
    tiles_online : bool
        The page fetches online tiles (its security policy allows images over https).
    heartbeat_s : float
        Seconds between keep-alive comments on ``/events``.

    Returns
    -------
    starlette.applications.Starlette

    Raises
    ------
    trackmap.errors.MissingDependencyError
        starlette is not installed (``pip install antikol[serve]``).
    """
    require_serve()
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import HTMLResponse, JSONResponse, Response, StreamingResponse
    from starlette.routing import Route

    def allowed(request: Request) -> bool:
        if token is None:
            return True
        given = request.query_params.get("token")
        auth = request.headers.get("authorization", "")
        if given is None and auth.lower().startswith("bearer "):
            given = auth[7:].strip()
        return given is not None and secrets.compare_digest(given.encode(), token.encode())

    def guarded(
        handler: Callable[[Request], Awaitable[Response]],
    ) -> Callable[[Request], Awaitable[Response]]:
        async def run(request: Request) -> Response:
            if not allowed(request):
                return JSONResponse(
                    {"error": "an access token is required: add ?token=... to the address"},
                    status_code=401,
                )
            response = await handler(request)
            response.headers["X-Content-Type-Options"] = "nosniff"
            response.headers["Referrer-Policy"] = "no-referrer"
            response.headers["Cache-Control"] = "no-store"
            return response

        return run

    async def index(_request: Request) -> Response:
        return HTMLResponse(page, headers={"Content-Security-Policy": _csp(tiles_online)})

    async def snapshot(_request: Request) -> Response:
        return JSONResponse(view.latest)

    async def health(_request: Request) -> Response:
        return JSONResponse(
            {"ok": True, "cycles": view.cycles, "viewers": view.viewers, "ended": view.ended}
        )

    async def events(_request: Request) -> Response:
        sub = view.subscribe()

        async def stream() -> AsyncIterator[str]:
            try:
                yield "retry: 2000\n\n"
                while True:
                    try:
                        snap = await asyncio.wait_for(sub.get(), timeout=heartbeat_s)
                    except TimeoutError:
                        yield ": keep-alive\n\n"
                        continue
                    kind = "end" if snap.get("end") else "snapshot"
                    yield f"event: {kind}\ndata: {json.dumps(snap, separators=(',', ':'))}\n\n"
            finally:
                view.unsubscribe(sub)

        return StreamingResponse(
            stream(),
            media_type="text/event-stream",
            headers={"X-Accel-Buffering": "no"},
        )

    @contextlib.asynccontextmanager
    async def lifespan(_app: Any) -> AsyncIterator[None]:
        task = None
        if feed is not None:

            async def run_feed() -> None:
                try:
                    await feed()
                except asyncio.CancelledError:
                    raise
                except Exception:
                    logger.exception("the live view's feed failed")

            task = asyncio.create_task(run_feed())
        try:
            yield
        finally:
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task

    routes = [
        Route("/", guarded(index), methods=["GET"]),
        Route("/events", guarded(events), methods=["GET"]),
        Route("/snapshot", guarded(snapshot), methods=["GET"]),
        Route("/health", guarded(health), methods=["GET"]),
    ]
    return Starlette(routes=routes, lifespan=lifespan)


def run(app: Any, *, host: str = "127.0.0.1", port: int = 8765, log_level: str = "warning") -> None:
    """Serve ``app`` with uvicorn until interrupted (Ctrl-C).

    Parameters
    ----------
    app : ASGI app
        From :func:`create_app`.
    host, port
        Address to bind (default loopback).
    log_level : str
        uvicorn's log level.
    """
    require_serve()
    import uvicorn

    # viewers' event streams never end by themselves: do not wait for them on shutdown
    uvicorn.run(
        app,
        host=host,
        port=port,
        log_level=log_level,
        access_log=False,
        timeout_graceful_shutdown=2,
    )


class ServerThread:
    """Serve an app from a background thread, on a port of its own (tests, embedding).

    Use as a context manager: on entry the server is listening and :attr:`url` is its
    address; on exit it is stopped (its feed cancelled).

    Parameters
    ----------
    app : ASGI app
        From :func:`create_app`.
    host : str
        Address to bind (default loopback).
    port : int
        Port; 0 (default): a free one chosen by the system.
    start_timeout_s : float
        Longest wait for the server to start, s.
    """

    def __init__(
        self, app: Any, *, host: str = "127.0.0.1", port: int = 0, start_timeout_s: float = 30.0
    ) -> None:
        require_serve()
        import uvicorn

        self._sock = socket.socket(
            socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM
        )
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.bind((host, port))
        self.port = int(self._sock.getsockname()[1])
        shown = f"[{host}]" if ":" in host else host
        #: The server's address, e.g. ``http://127.0.0.1:45678/``.
        self.url = f"http://{shown}:{self.port}/"
        config = uvicorn.Config(
            app, log_level="warning", access_log=False, lifespan="on", timeout_graceful_shutdown=2
        )
        self._server = uvicorn.Server(config)
        self._timeout = start_timeout_s
        self._thread = threading.Thread(
            target=self._server.run, kwargs={"sockets": [self._sock]}, daemon=True
        )

    def __enter__(self) -> ServerThread:
        self._thread.start()
        waited = 0.0
        while not self._server.started:
            if not self._thread.is_alive() or waited > self._timeout:
                self.__exit__()
                raise RuntimeError(f"the server at {self.url} did not start")
            threading.Event().wait(0.02)
            waited += 0.02
        return self

    def __exit__(self, *exc: object) -> None:
        self._server.should_exit = True
        self._thread.join(timeout=self._timeout)
        self._sock.close()
