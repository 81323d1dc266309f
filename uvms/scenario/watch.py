"""Edit a model and see it: rerun a job whenever its scenario, its model or a file the model uses changes.

The files watched are the scenario file, the model file, the files it includes (static ``xacro:include``,
read by :func:`uvms.model.includes.walk_xacro`), and the data beside the model (YAML such as
``hydrodynamics.yaml``, meshes) in the model's folder and its direct subfolders. Every folder is watched
non-recursively: an include that climbs to ``/`` watches that one file, never a tree. Changes are debounced (an
editor's several writes give one rerun) through ``watchfiles``. ``uvms run/workspace ... --watch`` runs each
job in a child process: a change during a run stops it with SIGINT, and the run folder keeps the previous
complete run (``uvms.io.outputs.run_folder``).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UVMSError
from ..model import includes, resources
from ..model.packages import package_index

#: Files beside a model that a change of should rerun the job (data the model or uvms reads).
MODEL_DATA_SUFFIXES = (".xacro", ".urdf", ".yaml", ".yml", ".stl", ".dae", ".obj", ".ply")
#: The most direct subfolders of a model folder watched for its data (``meshes/``); more: none of them.
MAX_DATA_SUBFOLDERS = 32
#: Milliseconds of quiet before a rerun.
DEBOUNCE_MS = 300
#: Seconds a cancelled run has to stop after SIGINT before it is killed.
CANCEL_GRACE = 10.0


def real(path: str | os.PathLike) -> Path:
    """The path with its symbolic links resolved; a link loop stays as named (``Path.resolve`` raises on one)."""
    return Path(os.path.realpath(path))


def model_files(source: str | os.PathLike) -> set[Path]:
    """The model file (a path or a shipped model name) and the files it includes (resolved), ``$(find pkg)/...``
    ones too through the packages of ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH`` and the model's workspace."""
    path = resources.resolve_model_path(source)
    if not path.name.endswith(".xacro"):
        return {real(path)}
    packages = package_index(None, path)
    return set(includes.walk_xacro(path, packages).files)  # a walk that stopped (a cap): the files found


def scenario_model(scenario: Path) -> str | None:
    """The ``[model] path`` of a scenario file as a path or shipped name, or None when it cannot be read."""
    from .schema import read_toml  # the one bounded reader of scenario files

    try:
        model = read_toml(scenario).get("model", {}).get("path")
    except (UVMSError, AttributeError):
        return None
    if not isinstance(model, str):
        return None
    relative = scenario.parent / model
    return str(relative) if relative.exists() else model


def scenario_named_files(scenario: Path) -> list[str]:
    """The files a scenario names besides its model (:meth:`~uvms.scenario.spec.ScenarioSpec.named_files`); none
    when it cannot be read (the run reports why)."""
    from .schema import read_scenario

    try:
        return read_scenario(scenario).named_files()
    except UVMSError:
        return []


@dataclass
class WatchedFiles:
    """Which changes rerun a job: listed files, and model data in the model folders (and their direct subfolders),
    outside ``ignore``."""

    files: set[Path] = field(default_factory=set)
    folders: set[Path] = field(default_factory=set)
    ignore: tuple[Path, ...] = ()

    @classmethod
    def of(cls, scenario: Path | None = None, model: str | os.PathLike | None = None,
           ignore: Sequence[Path] = ()) -> WatchedFiles:
        """The files of a scenario and its model, or of a model alone; unreadable parts are skipped.

        The model's data folder is the folder of the model file (where ``hydrodynamics.yaml`` is looked up),
        not the folders of its includes: an include is watched as one file.
        """
        files: set[Path] = set()
        folders: set[Path] = set()
        if scenario is not None:
            files |= {real(scenario), *(real(file) for file in scenario_named_files(Path(scenario)))}
            model = model or scenario_model(Path(scenario))
        if model is not None:
            try:
                files |= model_files(model)
                folders.add(real(resources.resolve_model_path(model).parent))
            except UVMSError:
                pass  # the job reports it; the scenario file is still watched
        if scenario is not None:
            folders.discard(real(scenario).parent)  # a scenario folder holds other scenarios
        return cls(files, folders, tuple(real(p) for p in ignore))

    def ignored(self, path: Path) -> bool:
        """Whether ``path`` is under ``ignore`` or in a run folder being written (``.uvms-*``)."""
        return any(path == root or root in path.parents for root in self.ignore) or any(
            ".uvms-" in part for part in path.parts)

    def roots(self) -> list[Path]:
        """The folders to hand to the watcher, each watched non-recursively: the parents of the files, the model
        folders and their direct subfolders (``meshes/``; none when there are more than ``MAX_DATA_SUBFOLDERS``)."""
        found = {path.parent for path in self.files} | set(self.folders)
        for folder in self.folders:
            try:
                subfolders = [Path(entry.path) for entry in os.scandir(folder)
                              if entry.is_dir() and not entry.name.startswith(".")]
            except OSError:
                continue
            if len(subfolders) <= MAX_DATA_SUBFOLDERS:
                found |= {sub for sub in subfolders if not self.ignored(sub)}
        return sorted(folder for folder in found if folder.is_dir())

    def wants(self, path: str | os.PathLike) -> bool:
        """Whether a change of ``path`` reruns the job: a listed file, or model data in a model folder or in one of
        its direct subfolders."""
        path = real(path)
        if self.ignored(path):
            return False
        if path in self.files:
            return True
        return path.suffix in MODEL_DATA_SUFFIXES and bool({path.parent, path.parent.parent} & self.folders)


def watch(source: str | os.PathLike | WatchedFiles, callback: Callable[[list[Path]], object], *,
          debounce_ms: int = DEBOUNCE_MS, stop_event=None, once: bool = False) -> None:
    """Call ``callback(changed files)`` after every (debounced) change of a model or scenario and its files.

    For notebooks and scripts: ``uvms.scenario.watch.watch("my_rov.urdf.xacro", lambda changed: rerun())``.
    Blocks until ``stop_event`` (a ``threading.Event``) is set or Ctrl-C.

    Args:
        source: a model file (or shipped name), a scenario ``.toml``, or a :class:`WatchedFiles`.
        callback: called with the changed files; the set of files is recomputed after each call
            (an edit may add an include).
        debounce_ms: quiet time before a change is reported [ms].
        stop_event: set it to stop watching.
        once: return after the first change (tests).
    """
    import watchfiles

    def files() -> WatchedFiles:
        if isinstance(source, WatchedFiles):
            return source
        path = Path(source)
        return WatchedFiles.of(scenario=path) if path.suffix == ".toml" else WatchedFiles.of(model=source)

    while stop_event is None or not stop_event.is_set():
        watched = files()
        for changes in watchfiles.watch(*watched.roots(), recursive=False,
                                        watch_filter=lambda _, p: watched.wants(p), debounce=debounce_ms,
                                        stop_event=stop_event, yield_on_timeout=False):
            callback(sorted({Path(p) for _, p in changes}))
            if once:
                return
            break  # the files may have changed: watch the new set


# ------------------------------------------------------------------ the CLI's rerun loop
def headline(metrics: dict) -> dict[str, float]:
    """The numbers one line compares between runs: errors and travel of a run, volumes of a workspace."""
    keys = ("max_position_error", "final_position_error", "arm_travel", "vehicle_travel", "max_joint_limit_violation")
    numbers = {key: float(metrics[key]) for key in keys if isinstance(metrics.get(key), (int, float))}
    for frame, volume in (metrics.get("volume") or {}).items():
        if isinstance(volume, (int, float)):
            numbers[f"volume {frame}"] = float(volume)
    return numbers


UNITS = {"max_position_error": "m", "final_position_error": "m", "arm_travel": "rad", "vehicle_travel": "m",
         "max_joint_limit_violation": "rad"}


def compare(before: dict[str, float], after: dict[str, float]) -> str:
    """``max_position_error 3.6e-10 → 4.1e-10 m, arm_travel 24.6 → 26.6 rad, ...`` (new keys alone)."""
    parts = []
    for key, value in after.items():
        unit = UNITS.get(key, "m^3" if key.startswith("volume") else "")
        old = f"{before[key]:.3g} → " if key in before else ""
        parts.append(f"{key} {old}{value:.3g} {unit}".rstrip())
    return ", ".join(parts)


def read_metrics(folder: Path) -> dict:
    """The metrics of a finished run (read with the caps of any file from elsewhere), {} if unreadable."""
    try:
        metrics = resources.read_json(folder / "metrics.json", "metrics", UVMSError)
    except UVMSError:
        return {}
    return metrics if isinstance(metrics, dict) else {}


@dataclass
class Rerun:
    """Runs one CLI job (``uvms run ...`` without ``--watch``) in a child process and reports it in one line."""

    argv: list[str]
    out: Path
    watched: Callable[[], WatchedFiles]
    say: Callable[[str], None] = print
    process: subprocess.Popen | None = None
    started: float = 0.0
    reason: str = "start"
    last: dict[str, float] = field(default_factory=dict)

    def start(self, reason: str) -> None:
        """Start the job (cancelling a running one first)."""
        self.cancel()
        self.reason, self.started = reason, time.perf_counter()
        self.process = subprocess.Popen([sys.executable, "-m", "uvms.cli", *self.argv], stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True, start_new_session=True)

    def cancel(self, announce: bool = True) -> None:
        """Stop a running job with SIGINT (its folder keeps the previous complete run); kill it if it hangs."""
        if self.process is None or self.process.poll() is not None:
            self.process = None
            return
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.communicate(timeout=CANCEL_GRACE)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.communicate()
        if announce:
            self.say(f"{time.strftime('%H:%M:%S')} run stopped: files changed again")
        self.process = None

    def poll(self) -> None:
        """Report a finished job in one line."""
        if self.process is None or self.process.poll() is None:
            return
        _, stderr = self.process.communicate()
        seconds = time.perf_counter() - self.started
        stamp = time.strftime("%H:%M:%S")
        if self.process.returncode == 0:
            numbers = headline(read_metrics(self.out))
            self.say(f"{stamp} {self.reason}: {compare(self.last, numbers)} ({seconds:.1f} s; figures in {self.out}/)")
            for line in stderr.splitlines():  # a good run's warnings (limits left, error above tolerance) still count
                if line.startswith("uvms: warning:"):
                    self.say(f"         {line}")
            self.last = numbers
        else:
            lines = [line for line in stderr.strip().splitlines() if line.strip()]
            message = lines[-1] if lines else f"exit status {self.process.returncode}"
            self.say(f"{stamp} {self.reason}: {message} (the last good result stays in {self.out}/)")
        self.process = None

    def loop(self, debounce_ms: int = DEBOUNCE_MS, stop_event=None) -> None:
        """Run once, then rerun on every change until Ctrl-C (which stops the job and re-raises)."""
        import watchfiles

        self.start("first run")
        try:
            while stop_event is None or not stop_event.is_set():
                watched = self.watched()
                for changes in watchfiles.watch(*watched.roots(), recursive=False,
                                                watch_filter=lambda _, p: watched.wants(p), debounce=debounce_ms,
                                                rust_timeout=200, yield_on_timeout=True, stop_event=stop_event):
                    self.poll()
                    if changes:
                        names = ", ".join(sorted({Path(p).name for _, p in changes}))
                        self.start(f"{names} changed")
                        break
        finally:
            self.cancel(announce=False)

def without_watch(argv: Iterable[str]) -> list[str]:
    """The command line of one job: ``--watch`` removed."""
    return [item for item in argv if item != "--watch"]
