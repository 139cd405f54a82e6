"""Making a job from the studio: one at a time per workspace, in a worker process, progress per stage, cancellable.

The worker runs the job through :func:`stencil_cad.api.run` (the command line's one implementation) into
``jobs/.making-<id>/output``, adds the picture and ``job.yaml`` (the config that reproduces the job with
``stencil-cad run job.yaml``) and ``job.zip`` of all of it, then renames the folder to ``jobs/<id>``.
Cancelling sends the worker SIGTERM: the run stops at its next check, its output folder discards what it
staged, and the studio removes the folder in the making. Nothing of a cancelled or failed job is kept.
"""

from __future__ import annotations

import multiprocessing
import queue
import shutil
import threading
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import names
from .workspace import Workspace, new_id

#: Name of the config that reproduces a job, in its folder and its zip.
JOB_YAML = names.JOB_YAML
JOB_ZIP = names.JOB_ZIP
#: The spray profile a job sprays with (when the page chose one), beside ``job.yaml``.
PROFILE_YAML = names.SPRAY_PROFILE_YAML


class Busy(Exception):
    """A job is already being made in this workspace."""


@dataclass
class Job:
    """A job being made (or made): its worker, the events it sent, and how it ended."""

    id: str
    process: Any
    events: list[dict[str, Any]] = field(default_factory=list)
    state: str = "running"
    started: float = field(default_factory=time.time)
    changed: threading.Condition = field(default_factory=threading.Condition)
    #: The workspace's job lock, held while the job runs.
    lock: Any = None

    def add(self, event: dict[str, Any]) -> None:
        """Record an event and wake whoever waits for one; the job's end frees the workspace."""
        with self.changed:
            self.events.append(event)
            if event["event"] in ("finished", "failed", "cancelled"):
                self.state = event["event"]
                if self.lock is not None:
                    self.lock.close()
                    self.lock = None
            self.changed.notify_all()


class Jobs:
    """The workspace's job maker: starts, follows and cancels the one job at a time."""

    def __init__(self, workspace: Workspace) -> None:
        self.ws = workspace
        self.current: Job | None = None
        self.lock = threading.Lock()
        self._ctx = multiprocessing.get_context("spawn")

    def start(self, cfg_json: dict[str, Any], picture: Path | None) -> Job:
        """Start making the job of ``cfg_json`` (a config as plain JSON values) from ``picture``.

        Raises:
            Busy: A job is being made.
        """
        with self.lock:
            if self.current is not None and self.current.state == "running":
                raise Busy("a job is being made; wait for it or cancel it first")
            lock = self._workspace_lock()
            job_id = new_id()
            making = self.ws.making_dir(job_id)
            events = self._ctx.Queue()
            proc = self._ctx.Process(
                target=work,
                args=(cfg_json, str(making), None if picture is None else str(picture), events),
                name=f"stencil-cad job {job_id[:8]}",
                daemon=False,
            )
            job = Job(job_id, proc, lock=lock)
            try:
                proc.start()
            except BaseException:
                lock.close()
                raise
            self.current = job
        threading.Thread(target=self._follow, args=(job, events), daemon=True).start()
        return job

    def _workspace_lock(self) -> Any:
        """Hold the workspace's job lock (another studio on the same workspace may be making one).

        Raises:
            Busy: Another studio holds it.
        """
        fh = open(self.ws.root / "job.lock", "a+b")  # noqa: SIM115 - held until the job ends
        try:
            import fcntl

            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # no flock (Windows): this studio's own one-at-a-time still holds
            pass
        except OSError:
            fh.close()
            raise Busy("another studio is making a job in this workspace; wait for it") from None
        return fh

    def _follow(self, job: Job, events: Any) -> None:
        """Pass the worker's events on until it ends; a worker that died without a word failed."""
        while True:
            try:
                event = events.get(timeout=0.2)
            except queue.Empty:
                if not job.process.is_alive():
                    break
                continue
            job.add(event)
            if event["event"] in ("finished", "failed", "cancelled"):
                break
        job.process.join()
        if job.state == "running":
            job.add({"event": "failed", "message": f"the worker stopped (exit {job.process.exitcode})"})
        if job.state != "finished":
            shutil.rmtree(self.ws.making_dir(job.id), ignore_errors=True)

    def get(self, job_id: str) -> Job | None:
        """The job being made (or last made) if it is ``job_id``."""
        job = self.current
        return job if job is not None and job.id == job_id else None

    def cancel(self, job_id: str) -> bool:
        """Stop making job ``job_id``; True if it was running. Its folder in the making is removed."""
        job = self.get(job_id)
        if job is None or job.state != "running":
            return False
        job.process.terminate()
        job.process.join(timeout=30)
        if job.process.is_alive():
            job.process.kill()
            job.process.join()
        shutil.rmtree(self.ws.making_dir(job_id), ignore_errors=True)
        if job.state == "running":
            job.add({"event": "cancelled"})
        return True


def work(cfg_json: dict[str, Any], making: str, picture: str | None, events: Any) -> None:
    """The worker process: make the job into ``making``, then move it into place; report to ``events``.

    Args:
        cfg_json: The job's config as plain JSON values.
        making: The folder ``jobs/.making-<id>`` (it must not exist).
        picture: The picture file, or None for the bundled example.
        events: A queue told ``{"event": "start"|"done", "stage"}``, then ``finished``, ``failed`` or ``cancelled``.
    """
    import os

    from .. import api, interrupts
    from ..errors import UserError
    from ..runtime import tune_process

    tune_process()
    folder = Path(making)
    try:
        with interrupts.as_interrupts():
            folder.mkdir(parents=True)
            cfg = api.load_config(cfg_json)
            result = api.run(
                cfg,
                folder / "output",
                progress=lambda event, stage: events.put({"event": event, "stage": stage}),
            )
            write_reproducible(folder, cfg_json, cfg.image if picture is not None else None, result.files)
            done = folder.parent / folder.name.split("-", 1)[1]
            os.replace(folder, done)
        sim = result.figures.simulate
        events.put({"event": "finished", "scielab": None if sim is None else sim.scielab})
    except KeyboardInterrupt:
        shutil.rmtree(folder, ignore_errors=True)
        events.put({"event": "cancelled"})
    except UserError as exc:
        shutil.rmtree(folder, ignore_errors=True)
        events.put({"event": "failed", "message": str(exc)})
    except Exception as exc:  # noqa: BLE001 - the page shows any failure; nothing is kept
        shutil.rmtree(folder, ignore_errors=True)
        events.put({"event": "failed", "message": f"internal error: {type(exc).__name__}: {exc}"})


def write_reproducible(folder: Path, cfg_json: dict[str, Any], image: Path | None, files: Any) -> None:
    """Add the picture, the spray profile chosen and ``job.yaml`` beside ``output/``, and ``job.zip`` of all of it.

    ``job.yaml`` names the picture and the profile by their file names, so ``stencil-cad run job.yaml`` in the unzipped
    folder makes the same files as the studio did (the bundled example keeps no image key).
    """
    import yaml

    data = dict(cfg_json)
    if image is not None:
        shutil.copyfile(image, folder / image.name)
        data["image"] = image.name
    else:
        data.pop("image", None)
    profile = (data.get("spray") or {}).get("profile")
    if isinstance(profile, str):
        # The measured can travels with the job: job.yaml names the copy beside it.
        shutil.copyfile(profile, folder / PROFILE_YAML)
        data["spray"] = {**data["spray"], "profile": PROFILE_YAML}
    elif isinstance(profile, dict):
        # One copy per paint, numbered in the mapping's order: spray_profile_1.yaml, ...
        copies = {}
        for n, (key, path) in enumerate(profile.items(), start=1):
            name = names.numbered_profile_yaml(n)
            shutil.copyfile(path, folder / name)
            copies[key] = name
        data["spray"] = {**data["spray"], "profile": copies}
    text = "# Made in the stencil-cad studio; `stencil-cad run job.yaml` makes the same files.\n"
    text += yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
    (folder / JOB_YAML).write_text(text, encoding="utf-8")
    with zipfile.ZipFile(folder / f"{JOB_ZIP}.part", "w", zipfile.ZIP_DEFLATED) as z:
        for p in sorted(folder.rglob("*")):
            if p.is_file() and not p.name.startswith(JOB_ZIP):
                z.write(p, p.relative_to(folder).as_posix())
    (folder / f"{JOB_ZIP}.part").replace(folder / JOB_ZIP)
