"""The one module that writes result files: atomic, all-or-nothing, never clobbering.

Files are first written into a staging folder *inside* the output folder (so it is on the
same file system and the parent folder need not be writable), each through a temporary
name. :meth:`OutputDir.commit` then sets aside the files it replaces, moves the new ones
into place and, if any step fails, puts everything back as it was.

Rules:

* A lock file (``.stencil-cad.lock``) is held from the moment the folder is opened, so a
  second run into the same folder fails at once.
* A staging folder left by a run that was killed (SIGKILL, power loss) is swept by the next
  run into that folder, with a warning saying so; files it had set aside are put back.
* ``--force`` replaces only files that a manifest written by stencil-cad lists with a
  SHA-256 that still matches (files the tool wrote and nobody changed since). Anything else
  is kept and named in :attr:`OutputDir.kept`; a file this run must write that is not the
  tool's own is refused before any work.
* Files are created with the user's umask (like ``open``), not ``mkstemp``'s 0600.
"""

from __future__ import annotations

import contextlib
import errno
import fnmatch
import hashlib
import io
import json
import logging
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import numpy as np

from . import interrupts
from .errors import OutputError, UserError
from .exchange.png import png_bytes
from .files import kind, read_bytes
from .names import MANIFEST, PLAN_JSON

log = logging.getLogger(__name__)

#: Written into every manifest so a later ``--force`` can tell it from a hand-written one.
GENERATOR = "stencil-cad"
LOCK = ".stencil-cad.lock"
STAGING_PREFIX = ".stencil-cad-staging-"
_ASIDE = "set-aside"


def manifest_header() -> dict:
    """Keys that mark a manifest as written by stencil-cad (see :meth:`OutputDir.owned`)."""
    return {"generator": GENERATOR, "manifest_version": 1}


#: Largest manifest read back, in bytes (a 10 m² mural's lists about 2,000 files).
MANIFEST_LIMIT = 64 << 20


def read_manifest(path: Path) -> dict | None:
    """The JSON object in a manifest file, or None when it is absent, not a regular file, or not JSON."""
    try:
        data = json.loads(read_bytes(path, "manifest", limit=MANIFEST_LIMIT))
    except (UserError, OSError, ValueError, RecursionError):
        return None
    return data if isinstance(data, dict) else None


def _umask() -> int:
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def file_mode() -> int:
    """Mode of a new file under the current umask (0644 under the usual 022)."""
    return 0o666 & ~_umask()


def sha256_file(path: Path) -> str:
    """SHA-256 of a file, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


_sha256 = sha256_file

_FIXES = {
    errno.ENOSPC: "the disk is full: free some space or choose another --out",
    errno.EDQUOT: "the disk quota is exceeded: free some space or choose another --out",
    errno.EROFS: "the file system is read-only: choose another --out",
    errno.EACCES: "permission denied: fix the folder's permissions or choose another --out",
    errno.EPERM: "not permitted: fix the folder's permissions or choose another --out",
    errno.ENOTDIR: "a part of the path is a file, not a folder: choose another --out",
    errno.ENAMETOOLONG: "the path is too long: choose a shorter --out",
    errno.EISDIR: "a folder is where a file should go: move it away or choose another --out",
    errno.EEXIST: "a file is where a folder should go: move it away or choose another --out",
    errno.EXDEV: "the files cannot be moved across file systems: choose another --out",
}


def os_error_message(exc: OSError, what: str, path: Path | str | None = None) -> str:
    """One line for an OS error: what failed, on which path, and the fix."""
    where = exc.filename if getattr(exc, "filename", None) else path
    fix = _FIXES.get(exc.errno or -1, f"{exc.strerror or exc}: check the path or choose another --out")
    return f"{what} {where}: {fix}"


class OutputDir:
    """A results folder written all-or-nothing.

    Opening it creates the folder if needed, takes the lock, sweeps a stale staging folder
    and creates this run's staging folder: any OS problem (read-only, full, not a folder,
    permission) is reported here, before the first stage.

    Args:
        path: The output folder.
        force: Replace files the tool wrote earlier (see the module docstring).
        allow_existing: Accept a non-empty folder (stage commands add files to a run's
            folder) but still refuse to replace a file unless ``force``.
        remove_stale: With ``force``, also remove the tool's unchanged files that this run
            does not write again (a whole run; stage commands keep other stages' files).

    Raises:
        OutputError: The folder is not empty and neither ``force`` nor ``allow_existing`` is
            set, the path is a file, another run holds the lock, or the folder cannot be written.
    """

    def __init__(
        self,
        path: Path | str,
        force: bool = False,
        allow_existing: bool = False,
        remove_stale: bool | None = None,
    ):
        self.path = Path(path)
        self.force = force
        self.allow_existing = allow_existing
        self.remove_stale = force and not allow_existing if remove_stale is None else remove_stale
        self.files: list[str] = []
        #: Files in the folder this run neither wrote nor replaced (names), for the summary.
        self.kept: list[str] = []
        #: Files of an earlier run this run removed (with --force), for the summary.
        self.removed: list[str] = []
        # The tool's own records of the folder (the manifest, the job's plan); stage commands update them in place.
        self.replaceable = {MANIFEST, PLAN_JSON}
        self._stage: Path | None = None
        self._lock_fd: int | None = None
        self._created = False
        self._owned: dict[str, str] | None = None
        # SHA-256 of staged files by name: a staged file is written once and never changed.
        self._sha: dict[str, str] = {}
        self._manifest_ours = False
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"output path is a file, not a folder: {self.path} (choose another --out)")
        try:
            self._open()
        except OSError as exc:
            self._release()
            raise OutputError(os_error_message(exc, "cannot write the output folder", self.path)) from None
        except BaseException:
            self._release()
            raise

    # ------------------------------------------------------------------ opening

    def _open(self) -> None:
        if not self.path.is_dir():
            missing = [p for p in (self.path, *self.path.parents) if not p.exists()]
            for p in self.path.parents:
                if p.exists() and not p.is_dir():
                    raise OutputError(
                        f"cannot create the output folder {self.path}: {p} is a file (choose another --out)"
                    )
            self.path.mkdir(parents=True, exist_ok=True)
            self._created = bool(missing)
        self._lock()
        self._sweep()
        if not (self.force or self.allow_existing):
            others = self._user_entries()
            if others:
                raise OutputError(
                    f"output folder is not empty: {self.path} (use --force to replace the files "
                    "stencil-cad wrote there, or another --out)"
                )
        self._stage = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=self.path))

    def _lock(self) -> None:
        import fcntl

        lock = self.path / LOCK
        for _ in range(5):
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno not in (errno.EAGAIN, errno.EACCES):
                    os.close(fd)
                    raise
                try:
                    pid = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
                except OSError:
                    pid = ""
                os.close(fd)
                who = f" (process {pid})" if pid.isdigit() else ""
                raise OutputError(
                    f"another stencil-cad run{who} is writing to {self.path}; wait for it to finish "
                    "or choose another --out"
                ) from None
            # The previous holder may have unlinked the file between our open and flock.
            try:
                same = os.fstat(fd).st_ino == os.stat(lock).st_ino
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
                self._lock_fd = fd
                return
            os.close(fd)
        raise OutputError(f"could not lock {lock}; try again")

    def _sweep(self) -> None:
        """Remove staging folders of killed runs (we hold the lock: no run is live)."""
        for entry in sorted(self.path.glob(STAGING_PREFIX + "*")):
            if not entry.is_dir() or entry.is_symlink():
                continue
            aside = entry / _ASIDE
            restored = []
            if aside.is_dir():
                # Killed mid-commit: put back what it had set aside and not yet replaced.
                for f in aside.iterdir():
                    if not (self.path / f.name).exists():
                        os.replace(f, self.path / f.name)
                        restored.append(f.name)
            shutil.rmtree(entry)
            log.warning(
                "removed %s, the staging folder of an interrupted earlier run%s",
                entry,
                f"; restored {', '.join(restored)}" if restored else "",
            )

    def _user_entries(self) -> list[str]:
        return sorted(
            p.name for p in self.path.iterdir() if p.name != LOCK and not p.name.startswith(STAGING_PREFIX)
        )

    def _release(self) -> None:
        if self._lock_fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path / LOCK)
            os.close(self._lock_fd)
            self._lock_fd = None
        if self._created:
            with contextlib.suppress(OSError):
                self.path.rmdir()  # only when empty: a failed first run leaves no folder
            self._created = False

    # ------------------------------------------------------------------ ownership

    def owned(self) -> dict[str, str]:
        """Files the folder's manifest says stencil-cad wrote: name → SHA-256.

        Empty when there is no manifest, or it is not one the tool wrote (no ``generator``
        key, or rows without a SHA-256).
        """
        if self._owned is None:
            self._owned = {}
            data = read_manifest(self.path / MANIFEST)
            if data is None:
                return self._owned
            ours = data.get("generator") == GENERATOR or ("stencil_cad" in data and "versions" in data)
            self._manifest_ours = bool(ours)
            rows = data.get("files") if ours else None
            if isinstance(rows, list):
                for row in rows:
                    if not isinstance(row, dict):
                        continue
                    name, sha = row.get("name"), row.get("sha256")
                    if isinstance(name, str) and isinstance(sha, str) and Path(name).name == name:
                        self._owned[name] = sha
        return self._owned

    def is_ours(self, name: str) -> bool:
        """True when ``name`` in the folder is a file the tool wrote, unchanged since."""
        p = self.path / name
        sha = self.owned().get(name)
        if name == MANIFEST:
            return self._manifest_ours and p.is_file() and not p.is_symlink()
        if sha is None or not p.is_file() or p.is_symlink():
            return False
        try:
            return sha256_file(p) == sha
        except OSError:
            return False

    def check_free(self, names: Iterable[str]) -> None:
        """Refuse up front (before any work) if a file this command will write is in the way.

        Args:
            names: File names, or shell patterns (``layer_*.stl``) matched against the folder.

        Raises:
            OutputError: Naming the first such file.
        """
        existing = self._user_entries() if self.path.is_dir() else []
        for name in names:
            if any(c in name for c in "*?["):
                for hit in fnmatch.filter(existing, name):
                    self._check_new(hit, in_run=False)
            else:
                self._check_new(name, in_run=False)

    def _check_new(self, name: str, in_run: bool = True) -> None:
        if in_run and name in self.files:
            raise OutputError(f"internal: {name} written twice in one run")
        final = self.path / name
        if not (final.exists() or final.is_symlink()):
            return
        if final.is_dir() and not final.is_symlink():
            raise OutputError(
                f"{final} is a folder where stencil-cad writes a file (move it away or choose another --out)"
            )
        with contextlib.suppress(OSError):
            mode = os.stat(final).st_mode
            if not stat.S_ISREG(mode):
                raise OutputError(
                    f"{final} is {kind(mode)}, not a regular file: stencil-cad replaces only regular files "
                    "(move it away, or choose another --out)"
                )
        if name in self.replaceable and (self.is_ours(name) or not final.exists()):
            return
        if not self.force:
            raise OutputError(f"{final} already exists (use --force to replace it)")
        if not self.is_ours(name):
            raise OutputError(
                f"{final} was not written by stencil-cad or was changed since, so --force keeps it "
                "(move it away, or choose another --out)"
            )

    # ------------------------------------------------------------------ writing

    @property
    def stage(self) -> Path:
        """The staging folder (inside the output folder)."""
        if self._stage is None:
            raise OutputError(f"internal: output folder {self.path} is already closed")
        return self._stage

    @contextlib.contextmanager
    def open_path(self, name: str) -> Iterator[Path]:
        """Yield a temporary path to write ``name`` to; it is kept only if the block succeeds.

        Args:
            name: File name inside the output folder (no sub-folders).

        Raises:
            OutputError: The file is in the way, or the OS refused the write (disk full ...).
        """
        self._check_new(name)
        final = self.stage / name
        tmp_path = self.stage / f".{name}.tmp"
        try:
            yield tmp_path
            if not tmp_path.exists() or tmp_path.stat().st_size == 0:
                raise OutputError(f"internal: writer produced no data for {name}")
            os.chmod(tmp_path, file_mode())
            os.replace(tmp_path, final)
            self.files.append(name)
        except OSError as exc:
            raise OutputError(
                os_error_message(exc, "cannot write", self.path / name) + "; no files were changed"
            ) from None
        finally:
            with contextlib.suppress(OSError):
                tmp_path.unlink(missing_ok=True)

    def write_bytes(self, name: str, data: bytes) -> None:
        """Write a file from bytes."""
        with self.open_path(name) as p:
            p.write_bytes(data)

    def write_text(self, name: str, text: str) -> None:
        """Write a UTF-8 text file."""
        self.write_bytes(name, text.encode("utf-8"))

    def write_json(self, name: str, obj) -> None:
        """Write a JSON file (numpy values converted)."""
        self.write_text(name, json.dumps(obj, indent=2, default=_json_default) + "\n")

    def write_png(self, name: str, image: np.ndarray) -> None:
        """Write a PNG from a uint8 array, or a float array in [0, 1]."""
        self.write_bytes(name, png_bytes(image))

    def write_npz(self, name: str, arrays: dict) -> None:
        """Write a compressed NPZ."""
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        self.write_bytes(name, buf.getvalue())

    def sha256(self, name: str) -> str:
        """SHA-256 of the staged file ``name``, hex; each file is read and hashed once a run.

        A job makes its file table twice (before and after the instruction sheet) and hashes
        ``layers.npz`` for its plan: on the bundled example the second table took 0.06 CPU-s.
        """
        if name not in self._sha:
            self._sha[name] = sha256_file(self.stage / name)
        return self._sha[name]

    def file_table(self) -> list[dict]:
        """Name, size and SHA-256 of every file written so far (staged)."""
        return [
            {"name": name, "bytes": (self.stage / name).stat().st_size, "sha256": self.sha256(name)}
            for name in self.files
        ]

    # ------------------------------------------------------------------ commit

    def _plan(self) -> tuple[list[str], list[str]]:
        """(files to set aside and replace, tool files to remove); fills :attr:`kept`."""
        written = set(self.files)
        replace = [n for n in self.files if (self.path / n).exists() or (self.path / n).is_symlink()]
        for n in replace:
            self._check_new(n, in_run=False)
        remove, kept = [], []
        for n in self._user_entries():
            if n in written:
                continue
            ours = self.is_ours(n)
            if self.remove_stale and ours:
                remove.append(n)
            elif not ours:
                kept.append(n)
        self.kept = kept
        return replace, remove

    def commit(self) -> list[Path]:
        """Move every staged file into place, all or nothing; returns the final paths.

        Raises:
            OutputError: A file could not be moved; the folder is left as it was before.
        """
        if self._stage is None:
            return []
        replace, remove = self._plan()
        aside = self._stage / _ASIDE
        set_aside: list[str] = []
        placed: list[str] = []
        # The moves and their rollback are not cut short by a signal: one received before them
        # (see interrupts) stops the run with nothing moved, one during them waits until they end.
        with interrupts.held():
            # The manifest goes last: a folder whose manifest is new has every new file.
            order = [n for n in self.files if n != MANIFEST] + [n for n in self.files if n == MANIFEST]
            try:
                if replace or remove:
                    aside.mkdir()
                for n in replace + remove:
                    os.replace(self.path / n, aside / n)
                    set_aside.append(n)
                for n in order:
                    os.replace(self._stage / n, self.path / n)
                    placed.append(n)
            except BaseException as exc:
                self._rollback(placed, set_aside)
                if isinstance(exc, OSError):
                    raise OutputError(
                        os_error_message(exc, "cannot move the results into", self.path)
                        + "; the folder was left as it was"
                    ) from None
                raise
            self.removed = remove
            shutil.rmtree(self._stage, ignore_errors=True)
            self._stage = None
            self._created = False
            self._release()
        return [self.path / n for n in self.files]

    def _rollback(self, placed: list[str], set_aside: list[str]) -> None:
        stage = self._stage
        assert stage is not None  # only called while committing a staged folder
        for n in placed:
            with contextlib.suppress(OSError):
                os.replace(self.path / n, stage / n)
        for n in set_aside:
            try:
                os.replace(stage / _ASIDE / n, self.path / n)
            except OSError as exc:  # pragma: no cover - the folder itself went away
                log.error("could not restore %s: %s (it is in %s)", n, exc, stage / _ASIDE)
                return

    def abort(self) -> None:
        """Discard everything staged and release the folder."""
        if self._stage is not None:
            aside = self._stage / _ASIDE
            if aside.is_dir() and any(aside.iterdir()):
                # A rollback could not restore everything: keep it for the next run's sweep.
                log.error("kept %s: it holds files that could not be put back", self._stage)
            else:
                shutil.rmtree(self._stage, ignore_errors=True)
            self._stage = None
        self.files.clear()
        self._sha.clear()
        self._release()


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "value"):
        return obj.value
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def plain(d: Mapping[str, object] | None) -> dict[str, object]:
    """Keep the JSON-friendly scalars of a report dict."""
    out: dict[str, object] = {}
    for k, v in (d or {}).items():
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, float) and not np.isfinite(v):
            v = None
        if isinstance(v, (int, float, str, bool, type(None))):
            out[k] = v
        elif isinstance(v, (list, tuple)) and all(isinstance(x, (int, float, str, bool)) for x in v):
            out[k] = list(v)
        elif isinstance(v, Mapping):
            out[k] = plain(v)
    return out
