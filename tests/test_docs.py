"""The documentation runs: every ```python block of the README (in order, in one namespace,
as a reader pastes them) and every docstring example of both packages."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

import antikol
import trackmap

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def readme_python_blocks() -> list[str]:
    """The ```python blocks of the README, in order."""
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_python_blocks():
    assert readme_python_blocks(), "the README shows no API example"


def test_readme_python_blocks_run_as_pasted(tmp_path):
    # a fresh interpreter in an empty directory: nothing of the test session leaks in, and
    # files the examples write land in tmp_path
    script = tmp_path / "readme_blocks.py"
    parts = []
    for i, code in enumerate(readme_python_blocks(), 1):
        parts.append(
            f"exec(compile({code!r}, 'README python block {i}', 'exec'), ns)  # block {i}\n"
        )
    script.write_text("ns = {}\n" + "".join(parts), encoding="utf-8")
    done = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-4000:]


def _modules(package) -> list[str]:
    names = [package.__name__]
    for info in pkgutil.walk_packages(package.__path__, prefix=package.__name__ + "."):
        if info.name.endswith("__main__"):
            continue  # running it would start the command line
        names.append(info.name)
    return names


@pytest.mark.parametrize("module_name", _modules(antikol) + _modules(trackmap))
def test_docstring_examples(module_name):
    module = importlib.import_module(module_name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{module_name}: {result.failed} docstring example(s) failed"
