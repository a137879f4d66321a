"""The bad-input corpus (issue 14): generated cases for every class of input a user can give
(command-line numbers, scene keys, field files, the other files read, output paths, signals),
each expecting its exit status, one line naming the setting or file at fault, and no traceback.

Hypothesis runs a few dozen examples per property in ``make test`` and a longer run with
``SONOLUX_HYPOTHESIS=long`` (``make test-all``).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from sonolux import cli

# make test draws the same examples every run (derandomize): a failure there is reproducible;
# make test-all's long profile explores new ones each time.
settings.register_profile("default", max_examples=40, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                 HealthCheck.too_slow])
settings.register_profile("long", max_examples=1500, deadline=None,
                          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                 HealthCheck.too_slow])
settings.load_profile(os.environ.get("SONOLUX_HYPOTHESIS", "default"))


@pytest.fixture(autouse=True)
def crash_logs_in_tmp(tmp_path, monkeypatch):
    """A crash log (of a bug this corpus finds) goes to the test's folder, not /tmp."""
    monkeypatch.setenv("SONOLUX_LOG_DIR", str(tmp_path))

REPO_SCENES = Path(__file__).resolve().parents[2] / "python" / "sonolux" / "data" / "scenes"
#: What must never reach a user's screen.
FORBIDDEN = ("Traceback", "panicked", "internal error", "PanicException")


def run(capsys, *argv) -> tuple[int, str, str]:
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def error_line(err: str) -> str:
    """The one error line of a failed run's stderr (warnings, notes and progress set aside)."""
    lines = [ln for ln in err.splitlines()
             if ln.strip() and not ln.startswith(("sonolux: warning", "sonolux: note"))
             and "error" in ln]
    assert len(lines) == 1, f"expected one error line, got:\n{err}"
    return lines[0]


def assert_usage_error(code: int, err: str, *names: str) -> str:
    """Exit status 2, one error line naming each of ``names``, nothing a user should not see."""
    assert code == 2, f"exit status {code}, stderr:\n{err}"
    for bad in FORBIDDEN:
        assert bad not in err, err
    line = error_line(err)
    for name in names:
        assert str(name) in line, f"{name!r} not named in: {line}"
    return line


@pytest.fixture(scope="session")
def field_file(tmp_path_factory) -> Path:
    """A small sound-and-light field of paper-small, baked once for the corpus."""
    path = tmp_path_factory.mktemp("hardening") / "field.h5"
    code = cli.main(["bake", "paper-small", "--rays", "3000", "--particles", "20000", "-q",
                     "-o", str(path)])
    assert code == 0
    return path


@pytest.fixture
def field_copy(field_file, tmp_path) -> Path:
    """A private copy of the field file, to damage."""
    dst = tmp_path / "copy.h5"
    shutil.copyfile(field_file, dst)
    return dst
