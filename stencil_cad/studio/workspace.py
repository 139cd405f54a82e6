"""The studio's workspace: the one folder it writes in (uploads, finished jobs, jobs being made), capped in size.

Every path the page names is an identifier the studio made (hex digits), looked up inside the workspace;
nothing the page sends becomes a path. A job is made in ``jobs/.making-<id>`` and renamed to
``jobs/<id>`` once it is whole, so a killed server leaves no half-written job where finished ones
are listed; the next start removes what such a server left in the making.
"""

from __future__ import annotations

import os
import re
import shutil
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from ..names import profile_yaml

#: Default cap on the workspace's size: 2 GB (the bundled example's job folder is about 30 MB).
DEFAULT_CAP_BYTES = 2 << 30
#: Identifiers the studio makes: 32 hex digits.
_ID = re.compile(r"^[0-9a-f]{32}$")
MAKING = ".making-"


def default_workspace() -> Path:
    """The default workspace: ``stencil_cad/studio`` in the user's cache folder (``XDG_CACHE_HOME`` or ``~/.cache``)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "stencil_cad" / "studio"


def new_id() -> str:
    """A fresh identifier for an upload or a job."""
    return uuid.uuid4().hex


def is_id(text: str) -> bool:
    """True when ``text`` is an identifier the studio makes (and so a safe file name)."""
    return bool(_ID.match(text))


@dataclass
class Workspace:
    """The studio's folder: ``uploads/`` (checked pictures), ``jobs/`` (finished jobs), ``tmp/`` (uploads being checked)."""

    root: Path
    cap_bytes: int = DEFAULT_CAP_BYTES

    def __post_init__(self) -> None:
        self.root = Path(self.root).expanduser().resolve()
        for sub in ("uploads", "jobs", "tmp", "cards", "profiles"):
            (self.root / sub).mkdir(parents=True, exist_ok=True)

    @property
    def uploads(self) -> Path:
        """Checked pictures, named ``<id><suffix>``."""
        return self.root / "uploads"

    @property
    def jobs(self) -> Path:
        """Finished jobs, one folder ``<id>`` each."""
        return self.root / "jobs"

    @property
    def cards(self) -> Path:
        """Calibration cards, one folder ``<id>`` each (made in ``.making-<id>`` like a job)."""
        return self.root / "cards"

    @property
    def profiles(self) -> Path:
        """Spray profiles the calibration fitted: ``<id>.yaml`` and what the fit found, ``<id>.json``."""
        return self.root / "profiles"

    def profile_path(self, profile_id: str) -> Path | None:
        """The spray profile ``profile_id``, or None."""
        if not is_id(profile_id):
            return None
        p = self.profiles / profile_yaml(profile_id)
        return p if p.is_file() else None

    def card_dir(self, card_id: str) -> Path | None:
        """The calibration card ``card_id``'s folder, or None."""
        if not is_id(card_id):
            return None
        p = self.cards / card_id
        return p if p.is_dir() else None

    @property
    def tmp(self) -> Path:
        """Uploads being checked (removed whether or not they pass)."""
        return self.root / "tmp"

    def sweep(self) -> list[str]:
        """Remove what a killed server left: jobs in the making and uploads being checked. Returns what went."""
        gone = []
        for p in [*self.jobs.iterdir(), *self.cards.iterdir()]:
            if p.name.startswith(MAKING):
                shutil.rmtree(p, ignore_errors=True)
                gone.append(p.name)
        for p in self.tmp.iterdir():
            _remove(p)
            gone.append(p.name)
        return gone

    def upload_path(self, upload_id: str) -> Path | None:
        """The checked picture of ``upload_id``, or None (also for anything that is not an identifier)."""
        if not is_id(upload_id):
            return None
        for p in self.uploads.glob(f"{upload_id}.*"):
            if p.is_file():
                return p
        return None

    def job_dir(self, job_id: str) -> Path | None:
        """The finished job ``job_id``'s folder, or None."""
        if not is_id(job_id):
            return None
        p = self.jobs / job_id
        return p if p.is_dir() else None

    def making_dir(self, job_id: str) -> Path:
        """Where job ``job_id`` is made, until it is whole."""
        if not is_id(job_id):
            raise ValueError(f"not a job identifier: {job_id!r}")
        return self.jobs / f"{MAKING}{job_id}"

    def finish(self, job_id: str) -> Path:
        """Move a whole job into place (one rename) and evict old jobs beyond the cap; returns its folder."""
        done = self.jobs / job_id
        os.replace(self.making_dir(job_id), done)
        self.evict(keep={job_id})
        return done

    def file_in(self, folder: Path, name: str) -> Path | None:
        """The regular file ``name`` (a relative path) inside ``folder``, or None if it leaves the folder or is missing."""
        if not name or name.startswith(("/", "\\")) or "\\" in name or "\x00" in name:
            return None
        base = folder.resolve()
        p = (base / name).resolve()
        if not p.is_relative_to(base) or not p.is_file():
            return None
        return p

    def finished_jobs(self) -> list[Path]:
        """Finished jobs' folders, newest first."""
        found = [p for p in self.jobs.iterdir() if p.is_dir() and is_id(p.name)]
        return sorted(found, key=lambda p: p.stat().st_mtime, reverse=True)

    def size_bytes(self) -> int:
        """Bytes the workspace's files take."""
        return sum(f.stat().st_size for f in self.root.rglob("*") if f.is_file())

    def evict(self, keep: set[str] | None = None) -> list[str]:
        """Remove the oldest finished jobs, then the oldest uploads, until the workspace is under its cap.

        Args:
            keep: Identifiers never removed (the job just finished, the picture in use).

        Returns:
            The identifiers removed.
        """
        keep = keep or set()
        gone: list[str] = []
        total = self.size_bytes()
        old = sorted(
            [*self.finished_jobs(), *(p for p in self.uploads.iterdir() if p.is_file())],
            key=lambda p: p.stat().st_mtime,
        )
        for p in old:
            if total <= self.cap_bytes:
                break
            ident = p.name.split(".")[0]
            if ident in keep:
                continue
            size = (
                sum(f.stat().st_size for f in p.rglob("*") if f.is_file()) if p.is_dir() else p.stat().st_size
            )
            _remove(p)
            total -= size
            gone.append(ident)
        return gone

    def touch(self, path: Path) -> None:
        """Mark ``path`` as just used, so eviction takes it last."""
        now = time.time()
        os.utime(path, (now, now))


def _remove(p: Path) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    else:
        p.unlink(missing_ok=True)
