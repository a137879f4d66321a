"""Shared fixtures: the small material library the scene tests use, and scene-file helpers.

The scene tests run against ``tests/data/materials_fixture.json`` so that they do not depend on
the values of the shipped library; tests that need the compiled core ask for ``core``.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from sonolux.materials import load_library

DATA = Path(__file__).resolve().parent / "data"
REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples" / "scenes"


@pytest.fixture(scope="session")
def library():
    """The fixture material library (plaster, concrete-painted, carpet-on-concrete, glass)."""
    return load_library(DATA / "materials_fixture.json")


@pytest.fixture
def core():
    """The compiled core; skips the test when it is not built (PYTHONPATH=python runs)."""
    return pytest.importorskip("sonolux._core")


@pytest.fixture
def write(tmp_path):
    """write(name, text) -> Path: a file in the test's directory, dedented."""

    def _write(name: str, text: str) -> Path:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
        return path

    return _write

