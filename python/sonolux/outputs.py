"""Every file sonolux writes is written beside its target and renamed into place.

``out/view.png`` is first written as ``out/view.partial-PID.png`` (a visible name with the
writer's process id, so that two runs to one target do not write into each other, and the
target's suffix, so that writers that go by it still work), given the permissions the umask
allows (``0o666 & ~umask``, as for any file a program creates), and renamed over the target
only when complete. So the target is always either the previous output, intact, or the new
one, complete. An interrupted run (Ctrl-C, SIGTERM: see :mod:`sonolux.cli.failures`) removes
its partial file; a killed one (SIGKILL, power loss) leaves it, visible, and the next run to
the same target removes it (a partial file whose process is gone). Folders (reports, web
bundles) get the same treatment from :func:`atomic_folder`.

A target that cannot be written (a read-only folder, a file where a folder should be, a full
disk) is an :class:`~sonolux.errors.OutputError` that names it.
"""

from __future__ import annotations

import contextlib
import glob
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from sonolux.errors import OutputError


def partial_path(path: str | Path, pid: int | None = None) -> Path:
    """``dir/name.partial-PID.ext`` for ``dir/name.ext``: where ``path`` is written first."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial-{pid or os.getpid()}{path.suffix}")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return pid < 2**22  # another user's process, or no such pid at all
    return True


def remove_leftovers(path: str | Path) -> list[Path]:
    """Removes the ``name.partial-PID.ext`` files beside ``path`` that killed runs left (their
    process is gone); returns what was removed."""
    path = Path(path)
    prefix, suffix = f"{path.stem}.partial-", path.suffix
    removed = []
    for p in path.parent.glob(glob.escape(prefix) + "*" + glob.escape(suffix)):
        pid = p.name[len(prefix): len(p.name) - len(suffix)]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)) and p.is_file():
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed


def umask_mode(directory: bool = False) -> int:
    """The mode a new file (0o666) or folder (0o777) gets under the current umask."""
    umask = os.umask(0)
    os.umask(umask)
    return (0o777 if directory else 0o666) & ~umask


def follow_umask(path: str | Path) -> None:
    """Gives ``path`` (a file, or a folder and everything in it) the umask's permissions;
    ``mkstemp`` and ``mkdtemp`` make them private (0600 / 0700)."""
    path = Path(path)
    if path.is_dir():
        for sub in path.rglob("*"):
            os.chmod(sub, umask_mode(sub.is_dir()))
    os.chmod(path, umask_mode(path.is_dir()))


def prepare_folder(path: str | Path) -> Path:
    """Creates the folder that will hold ``path``, or names ``path`` in an OutputError."""
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        raise OutputError(f"{path}: is a folder; give a file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path}: cannot create its folder {path.parent} "
                          f"({exc.strerror or exc})") from None
    return path


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yields the partial path to write; renames it onto ``path`` when the block ends well,
    removes it when it does not (an error, Ctrl-C, SIGTERM)."""
    path = prepare_folder(path)
    tmp = partial_path(path)
    try:
        remove_leftovers(path)
        tmp.unlink(missing_ok=True)
        tmp.touch()  # a folder that refuses files says so here, not inside a writer library
        yield tmp
        if not tmp.exists():
            raise OutputError(f"{path}: nothing was written")
        os.chmod(tmp, umask_mode())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(f"{path}: cannot write it ({exc.strerror or exc})") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomically(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Calls ``write(partial_path)`` and renames the result onto ``path``; returns ``path``."""
    with atomic_output(path) as tmp:
        write(tmp)
    return Path(path)


@contextlib.contextmanager
def atomic_folder(path: str | Path) -> Iterator[Path]:
    """Like :func:`atomic_output` for a folder (a report, a web bundle): yields the empty
    folder ``NAME.partial-PID`` beside ``path`` to fill; when the block ends well it gets the
    umask's permissions and replaces ``path`` (an old folder is moved to ``NAME.old-PID`` first
    and removed after, so ``path`` is always the old folder or the new one, whole)."""
    import shutil

    path = Path(path)
    tmp = path.with_name(f"{path.name}.partial-{os.getpid()}")
    old = path.with_name(f"{path.name}.old-{os.getpid()}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _remove_folder_leftovers(path)
        for mine in (tmp, old):
            if mine.is_dir():
                shutil.rmtree(mine)
        tmp.mkdir()
    except OSError as exc:
        raise OutputError(f"{path}: cannot write it ({exc.strerror or exc})") from None
    try:
        yield tmp
        follow_umask(tmp)
        if path.exists():
            os.replace(path, old)
        try:
            os.replace(tmp, path)
        except BaseException:
            if old.exists():
                os.replace(old, path)
            raise
        shutil.rmtree(old, ignore_errors=True)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise OutputError(f"{path}: cannot write it ({exc.strerror or exc})") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _remove_folder_leftovers(path: Path) -> list[Path]:
    """``NAME.partial-PID`` and ``NAME.old-PID`` folders beside ``path`` of processes gone."""
    import shutil

    removed = []
    for p in path.parent.glob(glob.escape(path.name) + ".*-*"):
        mark, _, pid = p.name[len(path.name) + 1:].partition("-")
        if (mark in ("partial", "old") and pid.isdigit() and int(pid) != os.getpid()
                and not _alive(int(pid)) and p.is_dir()):
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    return removed
