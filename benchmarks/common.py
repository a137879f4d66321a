"""What every benchmark script shares: how busy the machine is, and writing results atomically."""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path


def other_cpu_use(seconds: float = 0.5) -> float:
    """Fraction of all CPUs busy over `seconds` while this process sleeps (Linux /proc/stat;
    0 elsewhere). Other work on the machine (a compile, say) makes every rate noisy."""
    def sample():
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        return sum(v), v[3] + v[4]  # total, idle + iowait
    try:
        t0, i0 = sample()
        time.sleep(seconds)
        t1, i1 = sample()
    except (OSError, ValueError, IndexError):
        return 0.0
    return 1.0 - (i1 - i0) / max(t1 - t0, 1)


def machine_and_load(busy_start: float, busy_end: float) -> dict:
    """The results' "machine" entry: platform, Python, CPUs and how busy the others kept them;
    prints a warning when that was enough to make the rates noisy."""
    import platform

    if max(busy_start, busy_end) > 0.15:
        print(f"WARNING: other processes kept {busy_start:.0%} of the CPUs busy at the start, "
              f"{busy_end:.0%} at the end: the rates are noisy, run again on an idle machine.")
    return {"platform": platform.platform(), "python": platform.python_version(),
            "cpus": os.cpu_count(), "other_cpu_use_start_end": [busy_start, busy_end]}


def write_json(path: Path, data: dict) -> None:
    """Writes `data` as JSON to a temporary file beside `path`, then renames it into place with
    the umask's permissions (``mkstemp`` makes it private)."""
    from sonolux.outputs import follow_umask

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=2, default=str)
            f.write("\n")
        follow_umask(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_peer(package: str, importer, allow_install: bool, log=print):
    """(whatever `importer()` returns, or None; a note) for a benchmark-only peer, pip-installing
    `package` into this interpreter when it is missing and `allow_install` is true."""
    import importlib
    import subprocess
    import sys

    try:
        return importer(), "already installed"
    except ImportError:
        pass
    if not allow_install:
        return None, f"{package} missing and --no-install given"
    log(f"{package} missing: pip install {package} (benchmark-only dependency)")
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", package],
                       check=False, capture_output=True, text=True)
    if r.returncode != 0:
        return None, f"pip install {package} failed: {r.stderr.strip()[-300:]}"
    importlib.invalidate_caches()
    try:
        return importer(), "installed by this run"
    except ImportError as e:
        return None, f"{package} installed but does not import: {e}"
