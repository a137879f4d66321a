"""Every file sonolux writes is written beside its target and renamed into place.

``out/view.png`` is first written as ``out/view.partial.png`` (a visible name, with the
target's suffix so that writers that go by it still work), given the permissions the umask
allows (``0o666 & ~umask``, as for any file a program creates), and renamed over the target
only when complete. So the target is always either the previous output, intact, or the new
one, complete. An interrupted run (Ctrl-C, SIGTERM: see :mod:`sonolux.cli.failures`) removes
its partial file; a killed one (SIGKILL, power loss) leaves it, visible, and the next run to
the same target replaces it. Folders (reports, web bundles) get the same treatment from
:func:`follow_umask`, applied before their rename.

A target that cannot be written (a read-only folder, a file where a folder should be, a full
disk) is an :class:`~sonolux.errors.OutputError` that names it.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

from sonolux.errors import OutputError


def partial_path(path: str | Path) -> Path:
    """``dir/name.partial.ext`` for ``dir/name.ext``: where ``path`` is written first."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")


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
        tmp.unlink(missing_ok=True)  # a leftover of a killed run
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
    folder ``NAME.partial`` beside ``path`` to fill; when the block ends well it gets the
    umask's permissions and replaces ``path`` (an old folder is moved to ``NAME.old`` first and
    removed after, so ``path`` is always the old folder or the new one, whole)."""
    import shutil

    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    old = path.with_name(path.name + ".old")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        for leftover in (tmp, old):  # of a killed run
            if leftover.is_dir():
                shutil.rmtree(leftover)
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
