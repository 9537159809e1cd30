"""Maps by the names command lines and configurations use.

``default`` is the embedded Kraków map (:func:`~trackmap.defaults.load_default`),
``synthetic`` the drawn network with every feature (:mod:`trackmap.synthetic`, built on
the fly), ``none`` no map at all (the paper's sector rule alone); anything else is a map
file (:func:`~trackmap.storage.load`).

>>> load_named("none") is None
True
"""

from __future__ import annotations

from trackmap.defaults import load_default
from trackmap.network import TrackMap
from trackmap.storage import load

__all__ = ["load_named"]


def load_named(spec: str) -> TrackMap | None:
    """The map a name stands for (case does not matter for the names).

    Parameters
    ----------
    spec : str
        ``default``, ``synthetic``, ``none`` or the path of a map file.

    Returns
    -------
    TrackMap or None
        None for ``none``.

    Raises
    ------
    trackmap.errors.TrackMapError
        The map file is missing, unreadable or broken (the message names it).
    """
    name = spec.lower()
    if name == "none":
        return None
    if name == "default":
        return load_default()
    if name == "synthetic":
        from trackmap.synthetic import demo_network  # the build side, only when asked

        return demo_network().build()
    return load(spec)
