"""Paths the tool reads and writes outside its output folder: regular files only, bounded.

A FIFO read blocks forever, ``/dev/zero`` reads without end, and writing "over" a device or
FIFO with ``--force`` replaced it with a regular file. So every input (image, config, spray
profile, ``card.json``, can lists, a stage's saved files) is checked to be a regular file
under a size limit before it is opened, and checked again on the open descriptor (the path
may change in between); every file written outside an :class:`~stencil_cad.output.OutputDir`
replaces only a regular file or nothing, through a temporary file that is removed if the
write fails (a full disk leaves nothing behind).
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from .errors import UserError

#: Size limits of the inputs, in bytes.
TEXT_LIMIT = 1 << 20  # a config, profile, card.json, can list or spray.json: 1 MiB
DATA_LIMIT = 4 << 30  # an image or a stage's saved intermediates (layers.npz, dots CSV): 4 GiB

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words ("a FIFO (named pipe)")."""
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def _check_stat(
    st: os.stat_result, path: Path, what: str, limit: int, error: type[UserError], fix: str
) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{what} {path} is {kind(st.st_mode)}, not a regular file ({fix})")
    if st.st_size > limit:
        raise error(
            f"{what} {path} is {st.st_size / 1e6:.1f} MB, more than the {limit / 1e6:.0f} MB stencil-cad "
            f"reads ({fix})"
        )


def check_input(
    path: Path | str,
    what: str,
    *,
    limit: int = TEXT_LIMIT,
    error: type[UserError] = UserError,
    fix: str = "give a regular file",
) -> os.stat_result:
    """Refuse a path that is missing, not a regular file, or larger than ``limit`` bytes.

    Args:
        path: The file.
        what: What it is, for the message ("config", "image").
        limit: Largest size accepted, in bytes.
        error: The :class:`UserError` subclass to raise.
        fix: What the user should do, for the message.

    Returns:
        The file's ``os.stat`` (symbolic links followed).

    Raises:
        UserError: ``error``, naming the path, what it is and the fix.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise error(f"{what} not found: {path} ({fix})") from None
    except PermissionError:
        raise error(f"cannot read {what} {path}: permission denied (fix its permissions)") from None
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc} ({fix})") from None
    _check_stat(st, path, what, limit, error, fix)
    return st


@contextlib.contextmanager
def open_input(
    path: Path | str,
    what: str,
    *,
    limit: int = TEXT_LIMIT,
    error: type[UserError] = UserError,
    fix: str = "give a regular file",
) -> Iterator[IO[bytes]]:
    """Open a regular file for reading in binary, checked before and after the open.

    The open itself cannot block: it is non-blocking, and a path that became a FIFO since
    the check is refused on the descriptor.

    Raises:
        UserError: As :func:`check_input`.
    """
    path = Path(path)
    check_input(path, what, limit=limit, error=error, fix=fix)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except PermissionError:
        raise error(f"cannot read {what} {path}: permission denied (fix its permissions)") from None
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc} ({fix})") from None
    try:
        _check_stat(os.fstat(fd), path, what, limit, error, fix)
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    with os.fdopen(fd, "rb") as fh:
        yield fh


def read_bytes(
    path: Path | str,
    what: str,
    *,
    limit: int = TEXT_LIMIT,
    error: type[UserError] = UserError,
    fix: str = "give a regular file",
) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (see :func:`open_input`)."""
    with open_input(path, what, limit=limit, error=error, fix=fix) as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:  # it grew since the check
        raise error(f"{what} {path} is more than the {limit / 1e6:.0f} MB stencil-cad reads ({fix})")
    return data


def read_text(
    path: Path | str,
    what: str,
    *,
    limit: int = TEXT_LIMIT,
    error: type[UserError] = UserError,
    fix: str = "give a regular file",
    encoding: str = "utf-8",
) -> str:
    """The text of a regular UTF-8 file of at most ``limit`` bytes.

    Raises:
        UserError: As :func:`check_input`, or the file is not text in ``encoding``.
    """
    data = read_bytes(path, what, limit=limit, error=error, fix=fix)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError:
        raise error(f"{what} {path} is not a text file ({fix})") from None


def check_target(path: Path | str, what: str, *, force: bool, error: type[UserError] = UserError) -> None:
    """Refuse to write ``path`` unless it is absent, or a regular file and ``force``.

    A symbolic link is judged by what it points to, and the write replaces the link itself.

    Raises:
        UserError: ``path`` is a folder, device, FIFO or socket (whatever ``force`` says),
            it exists and not ``force``, or its folder does not exist.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise error(f"cannot write {what} {path}: {exc.strerror or exc} (give another path)") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise error(
            f"{path} is {kind(st.st_mode)}, not a regular file: stencil-cad replaces only regular files "
            "(give another path)"
        )
    if st is not None and not force:
        raise error(f"{path} already exists (use --force to replace it, or give another path)")
    if not path.parent.is_dir():
        raise error(f"folder {path.parent} does not exist (create it first, or give another path)")


def write_text_over(
    path: Path | str, text: str, what: str, *, force: bool, error: type[UserError] = UserError
) -> None:
    """Write ``text`` to ``path`` whole or not at all, replacing only a regular file.

    The text goes to a new temporary file beside ``path``, which then replaces it; if
    anything fails (a full disk) the temporary file is removed and ``path`` is unchanged.

    Raises:
        UserError: As :func:`check_target`, or the OS refused the write (naming the fix).
    """
    path = Path(path)
    check_target(path, what, force=force, error=error)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        mode = 0o666
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), mode)
        with os.fdopen(fd, "wb") as fh:
            fh.write(text.encode("utf-8"))
            fh.flush()
            os.fsync(fh.fileno())
        check_target(path, what, force=force, error=error)  # it may have changed while we wrote
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise error(_write_error(exc, what, path)) from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _write_error(exc: OSError, what: str, path: Path) -> str:
    fixes = {
        errno.ENOSPC: "the disk is full: free some space or give another path",
        errno.EDQUOT: "the disk quota is exceeded: free some space or give another path",
        errno.EROFS: "the file system is read-only: give another path",
        errno.EACCES: "permission denied: fix the folder's permissions or give another path",
        errno.EPERM: "not permitted: fix the folder's permissions or give another path",
    }
    fix = fixes.get(exc.errno or -1, f"{exc.strerror or exc}: give another path")
    return f"cannot write {what} {path}: {fix}; nothing was written"
