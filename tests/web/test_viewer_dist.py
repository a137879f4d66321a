"""The built viewer shipped in the package (sonolux/web_dist) is there and was built from the
sources in web/ as they are now: `make web` rebuilds it after a change."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from sonolux.web.serve import VIEWER_DIR

WEB = Path(__file__).resolve().parents[2] / "web"


def sources_sha256(web: Path) -> str:
    """The hash vite.config.ts writes into build-info.json (same files, order and framing)."""
    files = sorted(p.relative_to(web).as_posix() for p in (web / "src").rglob("*") if p.is_file())
    files = sorted(files + ["index.html", "package-lock.json", "tsconfig.json", "vite.config.ts"])
    h = hashlib.sha256()
    for f in files:
        h.update(f.encode() + b"\0" + (web / f).read_bytes() + b"\0")
    return h.hexdigest()


def test_the_viewer_is_built_into_the_package():
    assert (VIEWER_DIR / "index.html").exists()
    assert list((VIEWER_DIR / "assets").glob("*.js"))


@pytest.mark.skipif(not (WEB / "src").is_dir(), reason="no web/ sources here (an installed package)")
def test_the_built_viewer_matches_its_sources():
    info = json.loads((VIEWER_DIR / "build-info.json").read_text())
    assert info["sources_sha256"] == sources_sha256(WEB), (
        "python/sonolux/web_dist is older than web/: run `make web` and commit the result")
