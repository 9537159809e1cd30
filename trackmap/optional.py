"""Optional dependencies: imported by the functions that need them, with a clear error.

``import trackmap``, loading a map and every query need none of these packages; reading
OSM XML/PBF needs osmium, progress bars tqdm, figures matplotlib (static) or folium
(interactive).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from trackmap.errors import MissingDependencyError

__all__ = ["EXTRAS", "require"]

#: The pip package and the extra of ``antikol`` that bring each optional module.
EXTRAS: dict[str, tuple[str, str]] = {
    "osmium": ("osmium", "osm"),
    "tqdm": ("tqdm", "osm"),
    "matplotlib": ("matplotlib", "plot"),
    "folium": ("folium", "plot"),
}


def require(module: str, *, purpose: str) -> ModuleType:
    """Import an optional module, or say which extra to install.

    Parameters
    ----------
    module : str
        Module name, a key of :data:`EXTRAS`.
    purpose : str
        What needs it, for the message (e.g. ``"reading city.osm.pbf"``).

    Returns
    -------
    module

    Raises
    ------
    trackmap.errors.MissingDependencyError
        The module is not installed (also an ``ImportError``).

    Examples
    --------
    >>> require("math", purpose="doctests").sqrt(4.0)
    2.0
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        package, extra = EXTRAS.get(module, (module, ""))
        hint = f"pip install 'antikol[{extra}]' (or pip install {package})"
        if not extra:
            hint = f"pip install {package}"
        raise MissingDependencyError(
            f"{purpose} needs {package}, which is not installed: {hint}"
        ) from exc
