"""``benchmarks/synthville.py`` loaded as a module (it is a script, not a package module)."""

from __future__ import annotations

import functools
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

_SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "synthville.py"


@functools.cache
def synthville() -> ModuleType:
    """The drawing script, loaded once per test session."""
    spec = importlib.util.spec_from_file_location("synthville", _SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up while defined
    spec.loader.exec_module(module)
    return module
