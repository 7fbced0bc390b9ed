"""Parallel, resumable demonstration generation: `ensure_demos` and `demo_path`.

    path = ensure_demos(preset, "kitchen/open_drawer", source="generated", workers=2)

One HDF5 file per (preset, task, source, demonstration set) under `preset.data.root`
(`data/` unless $ICIL_DATA sets it); training seed k of a table row trains on set k, whose
base seed is `seeding.data_set_seed(preset.seed, k)`:

    data/<preset>/<suite>/<task>/<source>.hdf5          (state observations)
    data/<preset>/<suite>/<task>/<source>_<obs>.hdf5    (rgb / rgbd observations)
    data/<preset>/<suite>/<task>/<source>.set<k>.hdf5   (demonstration set k > 0)

Each finished demo is written to its own shard (`<file>.parts/demo_NNNNNN.hdf5`), merged
into the file when all are done; demo i depends only on i and the base seed, so a resumed
run equals an uninterrupted one. A damaged or outdated file or shard is set aside (never
deleted) and generated again.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing as mp
import os
import re
import shutil
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

from icil_paper.config import DATA_ENV_VAR, Preset, get_preset
from icil_paper.data.hdf5 import DatasetError, merge_demo_files, verify_file, write_demos
from icil_paper.data.robomimic import robomimic_env_args
from icil_paper.data.sources import (
    MAX_ATTEMPTS,
    SOURCES,
    demo_seed,
    expert_rollout,
    make_source,
    source_env_options,
    style_dict,
)
from icil_paper.data.splits import sim_to_real_pairs
from icil_paper.fileio import check_writable, exclusive_lock, set_aside
from icil_paper.registry import check_name
from icil_paper.seeding import data_set_index
from icil_paper.setup.provenance import REPO_ROOT
from icil_paper.sim import (
    ACTION_DIM,
    ALL_SUITES,
    OBS_KINDS,
    all_tasks,
    get_suite,
    make_env,
    suite_of,
    suite_unavailable,
    tasks_of,
)

GENERATOR = "icil_paper.data.generate/5"
"""Written into every data set; bumped (old value into `OLDER_GENERATORS`) when demos change."""
OLDER_GENERATORS: dict[str, tuple[str, ...]] = {
    "icil_paper.data.generate/1": (),
    "icil_paper.data.generate/2": (),
    "icil_paper.data.generate/3": (),
    "icil_paper.data.generate/4": (),
}
"""Earlier values of `GENERATOR`, each with the sources whose data sets it made as this one
does; its files of any other source are outdated."""
DEFAULT_SCENES = "generated"
"""The `scenes` attribute a file without one was made on (files before generator 2)."""


class DemoGenerationError(RuntimeError):
    """The expert failed every attempt at one demo."""


def _preset(preset: Any):
    return preset if isinstance(preset, Preset) else get_preset(preset)


def _where(preset) -> str:
    return (f"data.root={preset.data.root} (set by --set data.root or ${DATA_ENV_VAR})"
            if preset.data.root else "data/ (data.root is not set)")


def data_root(preset: Any = None) -> Path:
    """Root of the data sets of `preset` (a Preset or a name): its `data.root`, else `data/`."""
    preset = _preset(preset)
    path = Path(preset.data.root) if preset.data.root else REPO_ROOT / "data"
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{_where(preset)} is a file, not a folder: point it at a "
                                 "folder (it is created when missing), or unset it for data/")
    return path


def check_data_folder(preset: Any) -> Path:
    """`data_root(preset)`, refused (naming the setting) when this process cannot write there."""
    preset = _preset(preset)
    path = data_root(preset)
    check_writable(path, _where(preset), "point data.root (or $ICIL_DATA) at a folder this "
                   "user can write to")
    return path


def demo_path(preset_name: Any, task: str, source: str, obs: str | None = None,
              seed: int | None = None) -> Path:
    """Where the data set of (preset, task, source) with base seed `seed` lives."""
    preset = _preset(preset_name)
    check_name("demo source", source, SOURCES)
    obs = check_name("observation kind", obs or preset.data.obs, OBS_KINDS)
    suite, _, rest = task.partition("/")
    if not suite or not rest or any(p in ("", ".", "..") for p in task.split("/")):
        raise ValueError(f"task name {task!r} is not of the form <suite>/<task>")
    stem = source if obs == "state" else f"{source}_{obs}"
    index = data_set_index(preset.seed if seed is None else seed)
    if index:
        stem = f"{stem}.set{index}"
    return data_root(preset) / preset.name / suite / rest / f"{stem}.hdf5"


def parts_dir(path: Path) -> Path:
    """Folder of the per-demo shard files of a data set being generated."""
    return path.with_name(path.name + ".parts")


def shard_path(path: Path, index: int) -> Path:
    return parts_dir(path) / f"demo_{index:06d}.hdf5"


@dataclass(frozen=True)
class _Job:
    task: str
    source: str
    obs: str
    index: int
    base_seed: int
    shard: str
    file_attrs: dict
    env_options: dict


_WORKER_CACHE: dict[tuple, tuple[Any, Any]] = {}
_CACHE_SIZE = 2
"""Envs (with their experts) a worker keeps open: one per (task, source) it recently served."""


def worker_init() -> None:
    """Initializer of a generation pool's worker processes: one torch thread each."""
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass


def _env_and_source(task: str, source: str, obs: str, env_options: dict) -> tuple[Any, Any]:
    key = (task, source, obs, tuple(sorted(env_options.items())))
    if key not in _WORKER_CACHE:
        while len(_WORKER_CACHE) >= _CACHE_SIZE:  # close the oldest env (memory)
            _close(_WORKER_CACHE.pop(next(iter(_WORKER_CACHE))))
        _WORKER_CACHE[key] = (make_env(task, obs=obs, seed=0, **env_options),
                              make_source(source, task))
    return _WORKER_CACHE[key]


def _close(pair: tuple[Any, Any]) -> None:
    for obj in reversed(pair):  # the source (expert) first, then the env
        close = getattr(obj, "close", None)
        if close is not None:
            close()


def _close_cache() -> None:
    while _WORKER_CACHE:
        _close(_WORKER_CACHE.pop(next(iter(_WORKER_CACHE))))


def generate_one(job: _Job) -> dict[str, Any]:
    """Make demo `job.index` (retrying on the next seeds), write its shard, return a summary."""
    env, policy = _env_and_source(job.task, job.source, job.obs, job.env_options)
    start = time.perf_counter()
    tried = []
    for attempt in range(MAX_ATTEMPTS):
        seed = demo_seed(job.base_seed, job.source, job.index, attempt)
        tried.append(seed)
        demo, ok = expert_rollout(env, policy, seed, source=job.source)
        if ok:
            demo.meta["attempt"] = attempt  # failed episodes before this one: keep-rate stats
            write_demos(job.shard, [demo], file_attrs=job.file_attrs, valid_fraction=0.0,
                        names=[f"demo_{job.index}"])
            return {"task": job.task, "index": job.index, "seed": seed, "attempts": attempt + 1,
                    "length": len(demo), "seconds": time.perf_counter() - start}
    raise DemoGenerationError(f"{job.task} ({job.source}): demo {job.index} failed all "
                              f"{MAX_ATTEMPTS} attempts (seeds {tried})")


def _finished_shards(path: Path) -> dict[int, Path]:
    """{demo index: shard} of the `demo_NNNNNN.hdf5` files in the data set's parts folder."""
    return {int(p.stem[len("demo_"):]): p for p in parts_dir(path).glob("demo_*.hdf5")
            if re.fullmatch(r"demo_\d+", p.stem)}


def outdated(info: dict[str, Any], source: str) -> str | None:
    """None when a file (its `file_info`) of `source` holds what this generator makes, else why."""
    made_by = str(info.get("generator", GENERATOR))
    if made_by == GENERATOR or source in OLDER_GENERATORS.get(made_by, ()):
        return None
    return (f"was made by {made_by}, which made {source} demonstrations differently from "
            f"this code's {GENERATOR}")


def _usable_shards(path: Path, source: str) -> dict[int, Path]:
    """The finished shards of a data set; damaged or outdated ones are set aside."""
    shards = _finished_shards(path)
    for index, shard in sorted(shards.items()):
        why = "outdated"
        try:
            problem = outdated(verify_file(shard), source)  # one demo each: cheap to read whole
        except DatasetError as exc:
            problem, why = str(exc), "corrupt"
        else:
            problem = problem and f"{shard}: {problem}"
        if problem is not None:
            moved = set_aside(shard, path.parent, why)
            warnings.warn(f"{problem}; moved it to {moved}; demo {index} will be generated "
                          "again", stacklevel=3)
            del shards[index]
    return shards


def _check_compatible(path: Path, attrs: dict[str, Any], info: dict[str, Any],
                      keys: tuple[str, ...] = ("task", "source", "obs_kind", "base_seed")) -> None:
    info = {"scenes": DEFAULT_SCENES, **info}
    for key in keys:
        if key in info and str(info[key]) != str(attrs[key]):
            raise DatasetError(
                f"{path}: was written with {key}={info[key]!r} but this run asks for "
                f"{attrs[key]!r}; move the file away (or pass the matching setting) to "
                "generate a new data set")


@dataclass
class _Plan:
    """One data set to complete: its file, attributes, demos present and indices missing."""

    task: str
    source: str
    path: Path
    attrs: dict[str, Any]
    have: set[int]
    missing: list[int]
    env_options: dict[str, Any]
    """`make_env` options of its envs: the caller's and the source's."""


def _plan(preset: Any, task: str, source: str, n: int, base_seed: int, obs: str,
          env_options: dict[str, Any], full_check: bool = False) -> _Plan:
    path = demo_path(preset, task, source, obs, seed=base_seed)
    control_freq = int(get_suite(suite_of(task)).control_freq)
    if "scenes" in env_options:
        raise ValueError("a data set's scene distribution follows its source "
                         "(sources.SOURCE_SCENES); generate without a `scenes` option")
    options = {**env_options, **source_env_options(source, task)}
    attrs: dict[str, Any] = {
        "task": task, "source": source, "obs_kind": obs, "base_seed": base_seed,
        "action_dim": ACTION_DIM, "generator": GENERATOR, "control_freq": control_freq,
        "scenes": options.get("scenes", DEFAULT_SCENES),
        "env_args": robomimic_env_args(task, obs, options, control_freq),
    }
    if source == "human":
        attrs["operator_style"] = json.dumps(style_dict())
    existing: list[str] = []
    if path.exists():
        try:
            info = verify_file(path, images=full_check)
        except DatasetError as exc:
            moved = set_aside(path)
            warnings.warn(f"{exc}; moved it to {moved} and generating the data set again",
                          stacklevel=3)
        else:
            _check_compatible(path, attrs, info)
            problem = outdated(info, source)
            if problem is None:  # made as this code makes it: its scenes must match too
                _check_compatible(path, attrs, info, ("scenes",))
                existing = info["demos"]
            else:
                moved = set_aside(path, why="outdated")
                warnings.warn(f"{path}: {problem}; moved it to {moved} and generating the data "
                              "set again", stacklevel=3)
    have = {int(name.split("_")[1]) for name in existing}
    shards = _usable_shards(path, source)
    missing = [i for i in range(n) if i not in have and i not in shards]
    return _Plan(task, source, path, attrs, have, missing, options)


def _merge(plan: _Plan) -> None:
    """Fold finished shards into the data set file (atomically) and remove them."""
    shards = _finished_shards(plan.path)
    if not shards:
        return
    parts = [(plan.path, f"demo_{i}", f"demo_{i}") for i in sorted(plan.have)]
    parts += [(shards[i], f"demo_{i}", f"demo_{i}") for i in sorted(shards) if i not in plan.have]
    parts.sort(key=lambda p: int(p[2].split("_")[1]))
    merge_demo_files(plan.path, parts, plan.attrs, split_seed=int(plan.attrs["base_seed"]))
    shutil.rmtree(parts_dir(plan.path), ignore_errors=True)


def ensure_many(preset: Any, tasks: Sequence[str], sources: Sequence[str], n: int | None = None,
                workers: int | None = None, progress: bool = True, seed: int | None = None,
                obs: str | None = None, full_check: bool = False,
                **env_options: Any) -> dict[tuple[str, str], Path]:
    """`ensure_demos` for every (task, source) pair, one worker pool for all; {pair: path}."""
    preset = _preset(preset)
    n = int(preset.data.demos_per_task if n is None else n)
    if n < 1:
        raise ValueError(f"demos per data set must be at least 1, got {n}")
    for task in tasks:
        suite_of(task)  # unknown task names fail here, listing the valid ones, before any work
    workers = int(preset.data.workers if workers is None else workers)
    base_seed = int(preset.seed if seed is None else seed)
    obs = obs or preset.data.obs
    pairs = [(task, source) for task in dict.fromkeys(tasks) for source in dict.fromkeys(sources)]
    with contextlib.ExitStack() as locks:
        # one writer per data set (as one per run folder): a second `demos` or `train` that
        # needs it waits here, then finds it whole; sorted, so two callers never deadlock
        for path in sorted({demo_path(preset, task, source, obs, base_seed)
                              for task, source in pairs}):
            locks.enter_context(data_set_lock(path))
        plans = [_plan(preset, task, source, n, base_seed, obs, env_options, full_check)
                 for task, source in pairs]
        _generate(plans, obs, base_seed, workers, progress)
    return {(plan.task, plan.source): plan.path for plan in plans}


def data_set_lock(path: Path) -> contextlib.AbstractContextManager:
    """The lock (`.<name>.lock` beside it) of the data set at `path`; none in a folder this
    process cannot write to (only a whole data set can be read there)."""
    folder = Path(os.path.abspath(path)).parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not os.access(folder, os.W_OK):  # a read-only mount or folder (access(2) says EROFS)
        return contextlib.nullcontext()
    return exclusive_lock(path.with_name(f".{path.name}.lock"), what=f"the data set {path}")


def _generate(plans: list[_Plan], obs: str, base_seed: int, workers: int,
              progress: bool) -> None:
    """Generate every missing demo of `plans` and merge each data set (the caller locks)."""
    jobs = []
    for plan in plans:
        folder = parts_dir(plan.path)
        if plan.missing:
            folder.mkdir(parents=True, exist_ok=True)
            for stale in folder.glob(".*.tmp"):  # temporary files of a killed run
                stale.unlink(missing_ok=True)
        jobs += [_Job(plan.task, plan.source, obs, i, base_seed, str(shard_path(plan.path, i)),
                      plan.attrs, plan.env_options) for i in plan.missing]
    if jobs:
        label = (f"{plans[0].task} [{plans[0].source}]" if len(plans) == 1
                 else f"{len(plans)} data sets")
        _run_jobs(jobs, workers, progress, f"demos {label}")
    for plan in plans:
        _merge(plan)


def ensure_demos(preset: Any, task: str, source: str, n: int | None = None,
                 workers: int | None = None, progress: bool = True, seed: int | None = None,
                 obs: str | None = None, full_check: bool = False,
                 **env_options: Any) -> Path:
    """Make sure the data set of (preset, task, source) holds at least `n` demos; return its path.

    Defaults come from the preset (`data.demos_per_task`, `data.workers`, `seed`);
    `full_check` also reads image arrays when checking an existing file for damage.
    """
    paths = ensure_many(preset, [task], [source], n=n, workers=workers, progress=progress,
                        seed=seed, obs=obs, full_check=full_check, **env_options)
    return paths[task, source]


def _run_jobs(jobs: list[_Job], workers: int, progress: bool, desc: str) -> None:
    bar = tqdm(total=len(jobs), desc=desc, unit="demo", disable=not progress)
    try:
        for summary in imap_jobs(generate_one, jobs, workers):
            bar.set_postfix(task=summary["task"], seed=str(summary["seed"]))
            bar.update()
    finally:
        _close_cache()  # the envs of this process (none when a pool ran the jobs)
        bar.close()


def imap_jobs(fn: Callable[[Any], Any], jobs: Sequence[Any], workers: int) -> Iterator[Any]:
    """`fn(job)` of every job, in this process (`workers` <= 1 or one job) or in a pool of
    `workers` spawned processes on one torch thread each; results as they finish. Jobs go
    out one at a time in order, so a worker mostly meets the task it has an env for."""
    if workers <= 1 or len(jobs) == 1:
        yield from map(fn, jobs)
        return
    with mp.get_context("spawn").Pool(min(workers, len(jobs)), initializer=worker_init) as pool:
        yield from pool.imap_unordered(fn, jobs)


class SuiteMissing(ValueError):
    """A suite the preset's tables need cannot run here (its message names the fix)."""


def check_tasks(preset: Any) -> None:
    """Refuse, before any work, a preset whose task lists name a task its suite lacks."""
    preset = _preset(preset)
    suites = {"robocasa_tasks": None, "zero_shot_tasks": "metaworld",
              "zero_shot_held_out": "metaworld", "maniskill_tasks": "maniskill"}
    for name, suite in suites.items():  # None: any suite's tasks
        for task in getattr(preset.data, name):
            owner = suite or task.split("/", 1)[0]
            valid = tasks_of(owner) if owner in ALL_SUITES else all_tasks()
            if valid:
                check_name(f"data.{name} task", task, valid)
    # the RoboCasa tables cannot be skipped: their suite must run here (ManiSkill's and the
    # Kinova tasks are left out with a note where they cannot)
    for suite in dict.fromkeys(t.split("/", 1)[0] for t in (*preset.data.robocasa_tasks,
                                                           *preset.data.zero_shot_tasks)):
        problem = suite_unavailable(suite) if suite in ALL_SUITES else None
        if problem:
            raise SuiteMissing(f"the {suite} suite, which the paper's RoboCasa tables run on, "
                               f"cannot run here: {problem}")


def preset_tasks(preset: Any, available: bool = False) -> tuple[str, ...]:
    """Every task of a preset's tables; `available=True` skips suites that cannot run here."""
    preset = _preset(preset)
    twins = sorted(set(sim_to_real_pairs().values()))
    tasks = tuple(dict.fromkeys((*preset.data.robocasa_tasks, *preset.data.zero_shot_tasks,
                                 *preset.data.zero_shot_held_out, *twins, *tasks_of("kinova"),
                                 *preset.data.maniskill_tasks)))
    if not available:
        return tasks
    problems = {suite: suite_unavailable(suite)
                for suite in dict.fromkeys(task.split("/", 1)[0] for task in tasks)}
    for suite, problem in problems.items():
        if problem:
            print(f"skipping the {suite} tasks: {problem}", file=sys.stderr)
    return tuple(task for task in tasks if not problems[task.split("/", 1)[0]])
