"""Fields for the web bundle tests: paper-small baked small, with and without its light."""

from __future__ import annotations

import pytest

from sonolux import cli, engine


@pytest.fixture(scope="session")
def sound_field(tmp_path_factory):
    """paper-small, sound only (1,500 rays)."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    path = tmp_path_factory.mktemp("fields") / "small.h5"
    assert cli.main(["bake", "paper-small", "-o", str(path), "--rays", "1500", "--no-light", "-q"]) == 0
    return path


@pytest.fixture(scope="session")
def lit_field(tmp_path_factory):
    """paper-small, sound and light."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    path = tmp_path_factory.mktemp("fields") / "lit.h5"
    assert cli.main(["bake", "paper-small", "-o", str(path), "--rays", "1500", "--particles", "50000",
                     "-q"]) == 0
    return path
