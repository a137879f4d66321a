"""Shared fixtures: the small material library the scene tests use, and scene-file helpers.

The scene tests run against ``tests/data/materials_fixture.json`` so that they do not depend on
the values of the shipped library; tests that need the compiled core ask for ``core``.
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import pytest

from sonolux import engine
from sonolux.errors import CoreMissingError
from sonolux.scene.materials import load_library

DATA = Path(__file__).resolve().parent / "data"
REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples" / "scenes"


@pytest.fixture(scope="session")
def library():
    """The fixture material library (plaster, concrete-painted, carpet-on-concrete, glass)."""
    return load_library(DATA / "materials_fixture.json")


def pytest_configure(config):
    """Without the compiled core almost nothing here can run: stop at once, saying how to build
    it, rather than skip. SONOLUX_TESTS_WITHOUT_CORE=1 runs the pure-Python tests alone."""
    if os.environ.get("SONOLUX_TESTS_WITHOUT_CORE") == "1":
        return
    try:
        engine.core()
    except CoreMissingError as exc:
        pytest.exit(f"{exc} (or set SONOLUX_TESTS_WITHOUT_CORE=1 to run the pure-Python tests "
                    "alone)", returncode=1)


@pytest.fixture
def core():
    """The engine gateway; skips the test only under SONOLUX_TESTS_WITHOUT_CORE=1."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    return engine


@pytest.fixture
def write(tmp_path):
    """write(name, text) -> Path: a file in the test's directory, dedented."""

    def _write(name: str, text: str) -> Path:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
        return path

    return _write

