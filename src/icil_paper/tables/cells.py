"""Compute a set of tables: one cell per trained policy, in this process, a process pool or Ray.

    plans = plan([table_spec(preset, "I")])       # one RunPlan per policy the tables train
    run_specs(preset, [table_spec(preset, "I")], executor="serial")  # or "local", "ray"

A cell (`RunPlan`, `run_cell`) trains one policy, evaluates it and measures its features,
each record stored as it finishes; a cell whose records are all stored is skipped, so a
killed run resumes. `run_jobs` runs cells on one of three executors: `serial` (this
process), `local` (`workers` spawned processes) or `ray` (one task each; the task gets the
files it reads through Ray's object store and returns those it wrote, which the driver
checks and writes, records last). A cell whose worker dies is retried; one that raises is
not, and one `CellsFailed` lists the failures after the other cells finish.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import logging
import math
import multiprocessing as mp
import os
import shutil
import socket
import sys
import tempfile
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from icil_paper import plugins
from icil_paper.commands import RayUnavailable
from icil_paper.config import DATA_ENV_VAR, Preset, get_preset
from icil_paper.config_data import from_dict, to_dict
from icil_paper.data import ensure_many
from icil_paper.data.generate import data_root, demo_path
from icil_paper.eval import evaluate_run_many, measure_features
from icil_paper.fileio import atomic_write_bytes, one_line
from icil_paper.records import eval_record, features_record, train_record
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore, canonical_json, results_root
from icil_paper.runspec import EvalSpec, FeatureSpec, RunSpec, eval_key, feature_key, tasks_tag
from icil_paper.seeding import seed_everything
from icil_paper.tables.spec import TableSpec
from icil_paper.train.rundir import RUNS_ENV_VAR, run_dir_for, runs_root
from icil_paper.train.stored import load_trained, train_run

EXECUTORS = ("serial", "local", "ray")
FORWARDED_ENV = ("ICIL_", "MUJOCO_GL")
"""Prefixes of the driver's environment variables that every Ray task runs with."""


# --------------------------------------------------------------------------- what to compute
@dataclass
class RunPlan:
    """One trained policy and everything the chosen tables measure on it: one cell."""

    run: RunSpec
    evals: dict[str, EvalSpec] = field(default_factory=dict)
    """eval key -> EvalSpec."""
    features: dict[str, FeatureSpec] = field(default_factory=dict)
    """feature key -> FeatureSpec."""


def plan(tables: Sequence[TableSpec]) -> list[RunPlan]:
    """The units of `tables` grouped by run, in first-seen order."""
    plans: dict[str, RunPlan] = {}
    for table in tables:
        for unit in table.units():
            p = plans.setdefault(unit.run.key(), RunPlan(unit.run))
            if unit.eval is not None:
                p.evals.setdefault(eval_key(unit.run, unit.eval), unit.eval)
            if unit.features is not None:
                p.features.setdefault(feature_key(unit.run, unit.features), unit.features)
    return list(plans.values())


def plan_records(p: RunPlan) -> list[tuple]:
    """The record ids (`ResultsStore.get` arguments) a cell writes, its training first."""
    return [train_record(p.run), *(eval_record(p.run, ev) for ev in p.evals.values()),
            *(features_record(p.run, f) for f in p.features.values())]


def plan_done(store: ResultsStore, p: RunPlan) -> bool:
    """True when every record of the cell is in the store."""
    return all(store.get(*record) is not None for record in plan_records(p))


def cell_label(run: RunSpec) -> str:
    return f"{run.label} {tasks_tag(run.data.tasks)} seed{run.seed}"


def data_needs(plans: Sequence[RunPlan]) -> dict[tuple, int]:
    """(task, source, obs, seed) -> demonstrations needed, over every plan."""
    need: dict[tuple, int] = {}

    def want(task: str, source: str, obs: str, seed: int, n: int) -> None:
        key = (task, source, obs, seed)
        need[key] = max(need.get(key, 0), n)

    for p in plans:
        d = p.run.data
        if d.dataset is None:
            for task in d.tasks:
                want(task, d.source, d.obs, d.seed, d.demos_for(task))
        if p.run.policy.type == "icrt":  # prompt pools
            for ev in p.evals.values():
                task = ev.prompt_task or ev.task
                want(task, ev.prompt_source, d.obs, d.seed, d.demos_for(task))
        for f in p.features.values():
            for task in f.data.tasks:
                want(task, f.data.source, f.data.obs, f.data.seed, f.start + f.data.demos_per_task)
    return need


def ensure_data(preset: Preset, plans: Sequence[RunPlan], progress: bool = True) -> None:
    """Generate every data set the plans read (one worker pool per observation kind)."""
    groups: dict[tuple, dict[tuple[str, str], int]] = {}
    for (task, source, obs, seed), n in data_needs(plans).items():
        groups.setdefault((obs, seed, n), {})[task, source] = n
    for (obs, seed, n), pairs in groups.items():
        ensure_many(preset, sorted({t for t, _ in pairs}), sorted({s for _, s in pairs}), n=n,
                    seed=seed, obs=obs, progress=progress, workers=preset.data.workers)


# --------------------------------------------------------------------------- one cell
def run_cell(preset: str, run: dict, evals: list[dict], features: list[dict],
             progress: bool = False, data_root: str | None = None) -> dict[str, Any]:
    """Train one run (or find it trained), evaluate it and measure its features; arguments
    are JSON (`data_root`: the driver's data folder). Returns a short summary."""
    store = ResultsStore(preset)
    preset = get_preset(preset)
    if data_root is not None:
        preset = preset.replace(data={"root": data_root})
    run_spec = RunSpec.from_dict(run)
    seed_everything(run_spec.seed)
    trained = train_run(run_spec, preset, store, progress=progress)
    policy = None

    def get_policy():
        nonlocal policy
        if policy is None:
            policy = load_trained(run_spec, preset, store, progress=progress)
        return policy

    # every task side by side, one batched forward pass a step; the envs stay in this
    # process for its next cell
    records = evaluate_run_many(run_spec, [from_dict(EvalSpec, e) for e in evals], get_policy,
                                store, preset, progress=progress, keep_envs=True)
    for f_dict in features:
        spec = from_dict(FeatureSpec, f_dict)
        store.run(*features_record(run_spec, spec),
                  lambda spec=spec: measure_features(get_policy(), spec, preset),
                  seed=run_spec.seed)
    successes = [r["metrics"]["success_rate"] for r in records]
    return {"run": run_spec.key(), "label": run_spec.label,
            "steps": trained["metrics"]["steps"], "evals": len(evals),
            "mean_success": float(np.mean(successes)) if successes else None}


def run_specs(preset: Preset, specs: Sequence[TableSpec], executor: str = "local",
              workers: int | None = None, ray_address: str | None = None,
              gpus_per_cell: float = 0.0, progress: bool = True) -> dict[str, Any]:
    """Compute every missing record of the tables `specs` (their data sets first, here);
    returns {run key: summary}."""
    store = ResultsStore(preset.name)
    # seed-major: a run stopped part-way leaves every row with about as many seeds
    todo = {p.run.key(): p for p in sorted(plan(specs), key=lambda p: p.run.seed)
            if not plan_done(store, p)}
    if not todo:
        return {}
    ensure_data(preset, list(todo.values()), progress=progress)
    jobs = [cell_job(preset, p, store, ray=executor == "ray") for p in todo.values()]
    return run_jobs(run_cell, jobs, executor=executor, workers=workers or preset.eval.workers,
                    gpus=gpus_per_cell, ray_address=ray_address, folders=cell_folders(preset),
                    progress=progress, done=lambda job: plan_done(store, todo[job.key]))


def cell_job(preset: Preset, p: RunPlan, store: ResultsStore, label: str | None = None,
             ray: bool = False) -> Job:
    """The job that computes cell `p` (`run_cell`); on Ray, with its input files."""
    return Job(p.run.key(), label or cell_label(p.run),
               {"preset": preset.name, "data_root": None if ray else preset.data.root,
                "run": p.run.to_dict(), "evals": [to_dict(e) for e in p.evals.values()],
                "features": [to_dict(f) for f in p.features.values()]},
               inputs=cell_inputs(preset, p, store) if ray else {})


def cell_folders(preset: Preset) -> dict[str, str]:
    """{environment variable: folder} of every folder a cell reads or writes."""
    return {RESULTS_ENV_VAR: str(results_root()), RUNS_ENV_VAR: str(runs_root()),
            DATA_ENV_VAR: str(data_root(preset))}


def cell_inputs(preset: Preset, p: RunPlan, store: ResultsStore) -> dict[str, list[str]]:
    """The files of `cell_folders` a cell reads (data sets, records, run folder), relative
    to their folders."""
    data, runs = data_root(preset), runs_root()
    demos = {demo_path(preset, task, source, obs).relative_to(data).as_posix()
             for task, source, obs, _ in data_needs([p])}
    records = [store.record_path(*r).relative_to(store.root).as_posix() for r in plan_records(p)]
    folder = run_dir_for(p.run, preset.name)
    run_files = [f.relative_to(runs).as_posix() for f in sorted(folder.glob("*"))
                 if f.is_file() and not f.name.startswith(".")] if folder.is_dir() else []
    return {DATA_ENV_VAR: sorted(demos), RESULTS_ENV_VAR: records, RUNS_ENV_VAR: run_files}


# --------------------------------------------------------------------------- any jobs
@dataclass(frozen=True)
class Job:
    """One call `fn(**kwargs)` of `run_jobs` (kwargs: plain JSON)."""

    key: str
    label: str
    kwargs: Mapping[str, Any]
    inputs: Mapping[str, Sequence[str]] = field(default_factory=dict)
    """Files it reads, {environment variable: paths relative to that folder} (Ray only)."""


@dataclass(frozen=True)
class Failure:
    label: str
    reason: str
    """One line."""
    attempts: int
    detail: str = ""
    """The traceback, or how the worker died."""


class CellsFailed(RuntimeError):
    """Some cells failed; the others finished (`results`: what they returned)."""

    def __init__(self, failures: list[Failure], results: dict[str, Any], total: int):
        self.failures, self.results = failures, results
        super().__init__("\n".join([f"{len(failures)} of {total} cells failed:",
                                    *(f"  {f.label}: {f.reason}" for f in failures)]))


def run_jobs(fn: Callable[..., Any], jobs: Sequence[Job], executor: str = "local",
             workers: int = 2, retries: int = 2, gpus: float = 0.0,
             ray_address: str | None = None, folders: Mapping[str, str] | None = None,
             done: Callable[[Job], bool] | None = None, progress: bool = True,
             recycle_gb: float | None = None) -> dict[str, Any]:
    """Run `fn(**job.kwargs)` on one torch thread for every job not `done`; return {key:
    result through JSON} in the jobs' order. `folders`: {environment variable: folder} jobs
    read and write; `recycle_gb` (local): a worker holding more memory after a job is
    replaced (default: the machine's memory / (workers + 1))."""
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; choose one of {', '.join(EXECUTORS)}")
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if len({j.key for j in jobs}) != len(jobs):
        raise ValueError("two jobs have the same key; a key names one job")
    todo = [j for j in jobs if done is None or not done(j)]
    if not todo:
        return {}
    bar = tqdm(total=len(todo), desc=f"cells ({executor})", unit="cell", disable=not progress)
    results: dict[str, Any] = {}
    failures: dict[str, Failure] = {}

    def finished(job: Job, result: Any = None, failure: Failure | None = None) -> None:
        if failure is None:
            results[job.key] = result
        else:
            failures[job.key] = failure
            bar.write(f"failed: {job.label}: {failure.reason}")
        bar.update()

    try:
        if executor == "serial":
            for job in todo:
                try:
                    finished(job, _call(fn, job.kwargs))
                except Exception as exc:  # a failing cell must not stop the others
                    finished(job, failure=Failure(job.label, one_line(exc), 1,
                                                  traceback.format_exc()))
        elif executor == "local":
            limit = recycle_gb or os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / (
                workers + 1) / 2**30
            _run_local(fn, todo, workers, retries, limit, finished, bar)
        else:
            _run_ray(fn, todo, workers, retries, gpus, ray_address, dict(folders or {}), done,
                     finished, bar)
    finally:
        bar.close()
    results = {j.key: results[j.key] for j in todo if j.key in results}
    if failures:
        raise CellsFailed([failures[j.key] for j in todo if j.key in failures], results,
                          len(todo))
    return results


@contextmanager
def _environ(env: Mapping[str, str]) -> Iterator[None]:
    """`env` set in os.environ while the block runs."""
    before = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        yield
    finally:
        for k, v in before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _call(fn: Callable[..., Any], kwargs: Mapping[str, Any], env: Mapping[str, str] = {},
          cwd: str | None = None) -> Any:
    """fn(**kwargs) on one torch thread (and with `env`, in `cwd`); its result through JSON."""
    torch = sys.modules.get("torch")
    threads = torch.get_num_threads() if torch else None
    where = os.getcwd()
    try:
        with _environ(env):
            if cwd:
                os.chdir(cwd)
            if torch:
                torch.set_num_threads(1)  # cells run side by side on the machine's cores
            return json.loads(canonical_json(fn(**kwargs)))
    finally:
        os.chdir(where)
        if torch:
            torch.set_num_threads(threads)


# --------------------------------------------------------------------------- local pool
def _load_plugins(names: list[str]) -> None:
    """The driver's --plugin modules and files (entry points: the registries find them)."""
    if names:
        plugins.load_plugins(names)


def _in_worker(fn: Callable[..., Any], kwargs: Mapping[str, Any]) -> tuple[Any, float]:
    """`_call` in a pool process, with the memory it holds afterwards (GiB)."""
    result = _call(fn, kwargs)
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except OSError:  # no /proc (macOS): never recycled
        pages = 0
    return result, pages * os.sysconf("SC_PAGE_SIZE") / 2**30


def _run_local(fn, todo, workers, retries, recycle_gb, finished, bar) -> None:
    """Each of `workers` slots is a one-process pool, so a dead process is its own job's."""
    def new_pool() -> cf.ProcessPoolExecutor:
        return cf.ProcessPoolExecutor(1, mp_context=mp.get_context("spawn"),
                                      initializer=_load_plugins, initargs=(plugins.named(),))

    pending, attempts = list(todo), dict.fromkeys((j.key for j in todo), 0)
    pools = [new_pool() for _ in range(min(workers, len(todo)))]
    running: dict[cf.Future, tuple[Job, int]] = {}

    def collect(future: cf.Future) -> None:
        job, slot = running.pop(future)
        n = attempts[job.key]
        try:
            result, held_gb = future.result()
        except cf.process.BrokenProcessPool:  # its process died: run again on a fresh one
            held_gb = math.inf
            if n <= retries:
                bar.write(f"retrying {job.label} (attempt {n + 1}): its worker died")
                pending.insert(0, job)
            else:
                finished(job, failure=Failure(
                    job.label, f"the worker process died (in each of {n} attempts)", n))
        except Exception as exc:  # the cell raised: not retried
            finished(job, failure=Failure(job.label, one_line(exc), n,
                                          "".join(traceback.format_exception(exc))))
            return
        else:
            finished(job, result)
        if held_gb > recycle_gb:  # dead, or holding a heavy cell's memory: a fresh process
            pools[slot].shutdown(wait=True)
            pools[slot] = new_pool()

    # the processes started meanwhile load torch and BLAS on one thread (cells run side by
    # side); this process's own thread pools are loaded already
    with _environ({"OMP_NUM_THREADS": "1"}):
        try:
            while pending or running:
                busy = {slot for _, slot in running.values()}
                for slot in [s for s in range(len(pools)) if s not in busy][:len(pending)]:
                    job = pending.pop(0)
                    attempts[job.key] += 1
                    running[pools[slot].submit(_in_worker, fn, job.kwargs)] = (job, slot)
                ready, _ = cf.wait(running, return_when=cf.FIRST_COMPLETED)
                for future in ready:
                    collect(future)
        finally:
            for pool in pools:
                pool.shutdown(wait=False, cancel_futures=True)


# --------------------------------------------------------------------------- Ray
def connect_ray(workers: int = 2, address: str | None = None) -> bool:
    """Join the Ray cluster at `address`, or start a local one with `workers` CPUs; True
    when this call connected (the caller then calls `ray.shutdown()`)."""
    try:
        import ray
    except ImportError as exc:
        raise RayUnavailable("Ray is not installed (`pip install -r requirements.txt` "
                             f"installs the pinned ray): {exc}") from None
    if ray.is_initialized():
        return False
    if address:
        check_reachable(address)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    logging.getLogger("ray._private.authentication.authentication_token_setup").setLevel(
        logging.ERROR)
    path = os.pathsep.join(p for p in map(os.path.abspath, sys.path) if os.path.isdir(p))
    options = {"log_to_driver": False, "logging_level": logging.WARNING,
               "runtime_env": {"env_vars": {"PYTHONPATH": path}}}  # e.g. a test's folder
    for attempt in range(1 if address else 3):  # a busy machine's raylet may start late
        try:
            if address:  # send ~/.ray/auth_token as `ray start` does
                from ray._private.authentication.authentication_token_setup import (
                    maybe_enable_token_auth_if_token_available,
                )
                maybe_enable_token_auth_if_token_available(warn_if_disabled=False)
                ray.init(address=address, **options)
            else:
                ray.init(address="local", num_cpus=workers, include_dashboard=False, **options)
            return True
        except Exception as exc:
            if ray.is_initialized():
                ray.shutdown()
            if address or attempt == 2:
                where = f"the Ray cluster at {address}" if address else "a local Ray"
                raise RayUnavailable(f"could not start or reach {where}: "
                                     f"{one_line(exc)}") from exc
    return True


def check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Fail at once, with the fix, when nothing answers at a `HOST:PORT` address."""
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or "://" in address:
        return  # "auto", "ray://...": left to Ray
    try:
        socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise RayUnavailable(
            f"nothing answers at {address} ({exc.strerror or exc}): start the cluster's head "
            f"there with `ray start --head --port {port}`, or give the head's address with "
            "--ray-address (or leave it out to start a local Ray)") from None


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _inside(path: str) -> PurePosixPath:
    """`path` as a relative path that stays inside its folder (ValueError otherwise)."""
    rel = PurePosixPath(path)
    if rel.is_absolute() or not rel.parts or ".." in rel.parts:
        raise ValueError(f"{path!r} is not a relative path inside its folder")
    return rel


def _fetch(ref: Any) -> bytes:
    import ray

    return ray.get(ref)


def _on_node(fn: Callable[..., Any], kwargs: Mapping[str, Any], env: Mapping[str, str],
             folders: list[str], names: list, inputs: list[tuple[str, str, str, Any]]
             ) -> dict[str, Any]:
    """A Ray task: `fn(**kwargs)` in private copies of `folders` made of `inputs`; returns
    its result, every file it wrote or changed, and the node it ran on."""
    _load_plugins(names)
    scratch = Path(tempfile.mkdtemp(prefix="icil-cell-"))
    try:
        roots = {var: scratch / f"folder{i}" for i, var in enumerate(folders)}
        for var, path, digest, ref in inputs:
            data = _fetch(ref)
            if _sha256(data) != digest:
                raise RuntimeError(f"the input {path} arrived damaged (its SHA-256 differs)")
            atomic_write_bytes(roots[var] / _inside(path), data)
        for root in [*roots.values(), scratch / "cwd"]:
            root.mkdir(parents=True, exist_ok=True)
        result = _call(fn, kwargs, {**env, **{v: str(r) for v, r in roots.items()}},
                       str(scratch / "cwd"))
        given = {(var, path): digest for var, path, digest, _ in inputs}
        files = []
        for var, root in roots.items():
            for path in sorted(p for p in root.rglob("*") if p.is_file()):
                rel = path.relative_to(root).as_posix()
                data = path.read_bytes()
                if not rel.startswith(".") and "/." not in rel \
                        and given.get((var, rel)) != _sha256(data):  # not locks, temporaries
                    files.append((var, rel, _sha256(data), data))
        ray = sys.modules.get("ray")
        node = ray.get_runtime_context().get_node_id() if ray and ray.is_initialized() else None
        return {"result": result, "files": files, "node": node}
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def read_inputs(job: Job, folders: Mapping[str, str], cache: dict | None = None
                ) -> list[tuple[str, str, str, bytes]]:
    """(variable, path, SHA-256, bytes) of each existing file `job.inputs` names."""
    cache = {} if cache is None else cache
    found = []
    for var, paths in job.inputs.items():
        for path in paths:
            if (var, path) not in cache:
                file = Path(folders[var]) / _inside(path)
                data = file.read_bytes() if file.is_file() else None  # else the job makes it
                cache[var, path] = data and (_sha256(data), data)
            if cache[var, path]:
                found.append((var, path, *cache[var, path]))
    return found


def install_files(files: list[tuple[str, str, str, bytes]], folders: Mapping[str, str],
                  sent: Sequence[tuple[str, str, str, Any]] = ()) -> int:
    """Check, then write atomically (records last) the files a Ray task returned into the
    driver's `folders`; return how many. ValueError names the first problem."""
    checked = []
    shipped = {(PurePosixPath(path).name, digest) for _, path, digest, _ in sent}
    for var, path, digest, data in files:
        if var not in folders:
            raise ValueError(f"a file came back for {var}, which is not one of the folders")
        target = Path(folders[var]) / _inside(path)
        if _sha256(data) != digest:
            raise ValueError(f"{path} came back damaged (its SHA-256 differs from the node's)")
        checked.append((var == RESULTS_ENV_VAR and target.suffix == ".json", target, data))
        shipped.add((target.name, digest))
    for is_record, target, data in checked:
        try:
            named = json.loads(data).get("files") or {} if is_record else {}
        except (ValueError, AttributeError):
            raise ValueError(f"the record {target.name} came back unreadable") from None
        for name, digest in named.items():
            if (name, digest) not in shipped:
                raise ValueError(f"the record {target.name} names {name} (SHA-256 "
                                 f"{str(digest)[:12]}..), which did not come back with it")
    for _, target, data in sorted(checked, key=lambda f: f[0]):  # records last
        atomic_write_bytes(target, data)
    return len(checked)


def _run_ray(fn, todo, workers, retries, gpus, address, folders, done, finished, bar) -> None:
    connected = connect_ray(workers, address)
    import ray

    refs: dict[Any, tuple[Job, list]] = {}
    nodes: dict[str, int] = {}
    try:
        if address is None and gpus > ray.cluster_resources().get("GPU", 0):
            raise ValueError(f"cells need {gpus} GPUs each; this Ray has none")
        task = ray.remote(_on_node)
        env = {k: v for k, v in os.environ.items() if k.startswith(FORWARDED_ENV)}
        stored: dict[tuple[str, str, str], Any] = {}  # a file many cells read travels once
        cache: dict = {}
        for job in todo:
            sent = []
            for var, path, digest, data in read_inputs(job, folders, cache):
                if (var, path, digest) not in stored:
                    stored[var, path, digest] = ray.put(data)
                sent.append((var, path, digest, stored[var, path, digest]))
            ref = task.options(num_cpus=1, num_gpus=gpus, max_retries=retries,
                               retry_exceptions=False, name=job.label[:100]).remote(
                fn, job.kwargs, env, list(folders), plugins.named(), sent)
            refs[ref] = (job, sent)
        while refs:
            (ref,), _ = ray.wait(list(refs), num_returns=1)
            job, sent = refs.pop(ref)
            try:
                answer = ray.get(ref)
                install_files(answer["files"], folders, sent)
            except ray.exceptions.RayTaskError as exc:  # the function raised
                cause = exc.cause if isinstance(exc.cause, BaseException) else exc
                finished(job, failure=Failure(job.label, one_line(cause), 1, str(exc)))
            except ray.exceptions.RayError as exc:  # its worker or node died each time
                finished(job, failure=Failure(job.label, f"the worker died in each of "
                                              f"{retries + 1} attempts", retries + 1, str(exc)))
            except (ValueError, OSError) as exc:
                finished(job, failure=Failure(job.label, f"its files did not come back "
                                              f"whole: {exc}", 1))
            else:
                if done is not None and not done(job):
                    finished(job, failure=Failure(job.label, "its node finished it, but its "
                                                  "records are not all in the store", 1))
                else:
                    nodes[answer["node"]] = nodes.get(answer["node"], 0) + 1
                    finished(job, answer["result"])
        if nodes:
            info = {n.get("NodeID"): n for n in ray.nodes()}
            bar.write("cells by node: " + "; ".join(
                f"{str(node)[:12]} ({info.get(node, {}).get('NodeManagerAddress', '?')}, "
                f"{info.get(node, {}).get('Resources', {}).get('GPU', 0):g} GPUs): {n}"
                for node, n in sorted(nodes.items(), key=lambda item: -item[1])))
    finally:
        for ref in refs:  # left only when the driver stops early (Ctrl-C, an error)
            ray.cancel(ref, force=True)
        if connected:
            ray.shutdown()
