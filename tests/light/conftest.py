"""Scenes and bakes the light tests share (baked once per session: a bake is the slow part)."""

from __future__ import annotations

import pytest

import sonolux
from sonolux import engine
from sonolux.light.bake import bake_light


def furnace_scene(rho=(0.5, 0.6, 0.7), power_w=12.0, size_m=(2.0, 2.0, 2.0)):
    """A closed shoebox whose every face emits (a surface light) and reflects ρ diffusely."""
    return sonolux.load_scene({
        "name": "furnace",
        "materials": {"glow": {"absorption": 0.1, "diffuse_rgb": list(rho), "specular": 0.0,
                               "roughness": 1.0}},
        "geometry": [{"type": "shoebox", "size_m": list(size_m), "materials": {"default": "glow"}}],
        "lights": [{"type": "surface", "material": "glow", "power_w": power_w}],
    })


@pytest.fixture(scope="session")
def small_scene(core):
    return sonolux.load_scene("paper-small")


@pytest.fixture(scope="session")
def small_light(small_scene):
    """paper-small's light, 60 000 particles (about 120 hits a patch)."""
    return bake_light(small_scene, particles=60_000)


@pytest.fixture(scope="session")
def core():  # the session-wide twin of tests/conftest.py's fixture
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    return engine
