"""The one module that writes result files: atomic, all-or-nothing, never clobbering.

Files are first written into a staging folder beside the output folder, each through a
temporary name and an ``os.replace``; :meth:`OutputDir.commit` then moves them into place.
A run that fails or is interrupted removes its staging folder, so it leaves no
half-written file and no partial set of outputs.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .errors import OutputError
from .exchange.png import png_bytes

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class OutputDir:
    """A results folder written all-or-nothing.

    Args:
        path: The output folder. Created on commit if missing.
        force: Replace files that already exist there.
        allow_existing: Accept a non-empty folder (stage commands add files to a run's
            folder) but still refuse to replace a file unless ``force``.

    Raises:
        OutputError: The folder is not empty and neither ``force`` nor ``allow_existing`` is set,
            or the path is a file.
    """

    def __init__(self, path: Path | str, force: bool = False, allow_existing: bool = False):
        self.path = Path(path)
        self.force = force
        self.allow_existing = allow_existing
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"output path is a file, not a folder: {self.path} (choose another --out)")
        if self.path.is_dir() and any(self.path.iterdir()) and not (force or allow_existing):
            raise OutputError(
                f"output folder is not empty: {self.path} (use --force to replace its files, or another --out)"
            )
        self._stage: Path | None = None
        self.files: list[str] = []
        # The tool's own record of the folder; stage commands update it in place.
        self.replaceable = {MANIFEST}

    @property
    def stage(self) -> Path:
        """The staging folder (created on first use)."""
        if self._stage is None:
            parent = self.path.parent
            parent.mkdir(parents=True, exist_ok=True)
            self._stage = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.partial-", dir=parent))
        return self._stage

    def check_free(self, names: list[str]) -> None:
        """Refuse up front (before any work) if a file this command will write already exists.

        Raises:
            OutputError: Naming the first such file.
        """
        for name in names:
            self._check_new(name)

    def _check_new(self, name: str) -> None:
        if name in self.files:
            raise OutputError(f"internal: {name} written twice in one run")
        final = self.path / name
        if final.exists() and not self.force and name not in self.replaceable:
            raise OutputError(f"{final} already exists (use --force to replace it)")

    @contextlib.contextmanager
    def open_path(self, name: str) -> Iterator[Path]:
        """Yield a temporary path to write ``name`` to; it is kept only if the block succeeds.

        Args:
            name: File name inside the output folder (no sub-folders).
        """
        self._check_new(name)
        final = self.stage / name
        fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=self.stage)
        os.close(fd)
        tmp_path = Path(tmp)
        try:
            yield tmp_path
            if not tmp_path.exists() or tmp_path.stat().st_size == 0:
                raise OutputError(f"internal: writer produced no data for {name}")
            os.replace(tmp_path, final)
            self.files.append(name)
        finally:
            if tmp_path.exists():
                tmp_path.unlink()

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

    def file_table(self) -> list[dict]:
        """Name, size and SHA-256 of every file written so far (staged)."""
        rows = []
        for name in self.files:
            p = self.stage / name
            rows.append({"name": name, "bytes": p.stat().st_size, "sha256": _sha256(p)})
        return rows

    def commit(self) -> list[Path]:
        """Move every staged file into the output folder; returns the final paths."""
        if self._stage is None:
            return []
        self.path.mkdir(parents=True, exist_ok=True)
        if self.force:
            self._remove_stale()
        out = []
        for name in self.files:
            final = self.path / name
            os.replace(self._stage / name, final)
            out.append(final)
        shutil.rmtree(self._stage, ignore_errors=True)
        self._stage = None
        return out

    def _remove_stale(self) -> None:
        """With --force, drop files an earlier run listed in its manifest that this run does not write."""
        old = self.path / MANIFEST
        if not old.exists():
            return
        try:
            listed = [row["name"] for row in json.loads(old.read_text()).get("files", [])]
        except (ValueError, KeyError, TypeError, AttributeError):
            return
        for name in listed:
            p = self.path / name
            if name not in self.files and p.is_file() and p.parent == self.path:
                p.unlink()

    def abort(self) -> None:
        """Discard everything staged."""
        if self._stage is not None:
            shutil.rmtree(self._stage, ignore_errors=True)
            self._stage = None
        self.files.clear()


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
