"""The live view for a control room: ``antikol serve``.

A small read-only web server shows the fleet moving on the network map with its current
threats, fed by the on-board units' radio stream (UDP) or by a recorded log replayed at
any speed:

* :class:`~antikol.serve.live.LiveView` runs the analyser and publishes a snapshot of the
  fleet every analysis cycle;
* :mod:`antikol.serve.feeds` feeds it (:func:`~antikol.serve.feeds.replay_feed`,
  :func:`~antikol.serve.feeds.udp_feed`);
* :func:`~antikol.serve.page.live_page` is its page (self-contained: Leaflet inlined, no
  request but to the server);
* :func:`~antikol.serve.app.create_app` is the ASGI app (starlette; server-sent events),
  served by uvicorn with :func:`~antikol.serve.app.run`.

It listens on loopback by default; bound to another address it requires an access token.
The web server's packages are optional (``pip install 'antikol[serve]'``): on-board use
never needs them, and nothing here imports them until an app is made.
"""

from __future__ import annotations

from antikol.serve.app import ServerThread, check_access, create_app, is_loopback, run
from antikol.serve.feeds import replay_feed, udp_feed
from antikol.serve.live import LiveView, Subscription
from antikol.serve.page import live_page

__all__ = [
    "LiveView",
    "ServerThread",
    "Subscription",
    "check_access",
    "create_app",
    "is_loopback",
    "live_page",
    "replay_feed",
    "run",
    "udp_feed",
]
