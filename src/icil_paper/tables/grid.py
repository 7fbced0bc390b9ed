"""Run a grid of independent experiment cells: in this process, on a local process pool, or on Ray.

The paper's tables are grids of independent cells (policy x tokenizer x data x seed: train,
then roll out). A `Cell` names one of them: a function given as `"module:function"`, its
JSON keyword arguments, the content key of what it computes and the CPUs/GPUs it needs. The
function stores its own result through the results store (`icil_paper.results`), so the
store, not the grid, is the record of what is finished: a rerun after a killed driver
passes `done=` (a predicate that looks the cell up in the store) and skips those cells.

    cells = [Cell(key=spec.key(), target="icil_paper.tables.execute:run_cell",
                  kwargs={"spec": spec_dict}, label=spec.label) for spec in specs]
    results = run_grid(cells, executor="local", workers=2, done=is_stored)

Executors
---------
- `serial`: one cell after another in this process (debugging; the reference the others
  are tested against).
- `local` (the default): `workers` spawned processes, one cell at a time each. Cells are
  started in order while their `cpus` fit into `workers` CPUs; `gpus` is not budgeted (the
  function picks its device). A worker whose resident memory after a cell is above
  `recycle_gb` is replaced by a fresh process before its next cell: a process can keep the
  memory of its heaviest cell (the allocator does not give it all back), so without this two
  workers that each met a heavy cell hold two peaks for the rest of the run. The memory
  measured is what the process holds when the cell returns, not its peak: on Linux a spawned
  process's `ru_maxrss` starts at its parent's resident memory (the peak survives `exec`), so
  a large driver would otherwise have every worker replaced after every cell.
- `ray`: one Ray task per cell with `num_cpus=cell.cpus`, `num_gpus=cell.gpus`. Without an
  address a private local Ray with `workers` CPUs is started and shut down at the end; with
  `ray_address` the driver joins that cluster (and only disconnects at the end). A Ray
  session the caller already started is used as it is. With `folders`, cells share no files
  with the driver (below).

Every executor runs a cell the same way: the driver's `ICIL_*` (and `MUJOCO_GL`) environment
variables, its working directory and its import path are applied in the worker for the
call, the plugins it loaded by name or file (`icil_paper.plugins`) are loaded there first,
torch runs on `threads` intra-op threads (1 by default, since cells run side by side),
and what the function returns is passed through JSON. Each function seeds itself
(`icil_paper.seeding.seed_everything`), so the same cells give the same results whatever
the executor and worker count.

Failures
--------
A cell whose worker process dies (killed, segfault, out of memory) is run again on a fresh
process, up to `retries` more times (Ray: the task's `max_retries`); a cell still dying
after that is reported as failed. A cell whose function raises is not retried: that is a
bug or a bad input, and running it again gives the same error. Either way the grid finishes
every other cell first (their results are stored by then), then raises one `GridError` that
lists each failed cell's label and one-line reason; `GridError.failures` holds the full
tracebacks.

Cells that share no files with the driver (`folders`, Ray)
-----------------------------------------------------------
Most Ray clusters share no filesystem: a node sees neither the driver's data sets nor its
results store, and what a cell writes there stays there. Given `folders` ({environment
variable: the driver's folder}, e.g. `ICIL_RESULTS`, `ICIL_RUNS`, `ICIL_DATA`), a Ray cell
runs detached (`_execute_detached`):

1. the driver reads the files the cell names in `Cell.inputs` ({variable: paths relative to
   that folder}: the data sets it reads, its records and run folder where they exist) and
   puts each into Ray's object store once (a data set read by fifty cells travels once);
2. on the node, the cell gets a private empty folder for each variable (the variable points
   there, its working directory is a private folder too), the inputs are written into them
   (their SHA-256 checked), and the cell runs as anywhere else;
3. every file the cell wrote or changed there (hidden files, i.e. locks and temporary files,
   excepted) comes back with its SHA-256, and the private folders are removed;
4. the driver checks every file's digest, and that every record among them (a JSON file in
   the `ICIL_RESULTS` folder) that names files (`files`: {name: SHA-256}) came back with
   those files, before it writes anything; then it writes them into its own folders
   atomically, records last, and asks `done(cell)`: a cell whose records are not all there
   failed.

Nothing relies on a path the driver and a node share; a node killed mid-cell takes only its
private folders with it, and Ray runs the cell again on another node (`retries`). The local
pool and the serial executor share the driver's files and run cells in place.

On a cluster
------------
1. Every node: this repository installed as `make setup` does (`.venv`), at any path.
2. Ray's token authentication: `ray get-auth-token --generate` on the head (it lands in
   `~/.ray/auth_token`); copy that file to every node and to the driver's machine (or set
   `RAY_AUTH_TOKEN`).
3. Head: `.venv/bin/ray start --head --port 6379` (`--num-cpus 0` keeps cells off it); every
   other node: `.venv/bin/ray start --address HEAD:6379` (`--num-gpus N` where there are GPUs).
4. Driver (any machine that reaches the head, holding the results store):
   `icil-paper reproduce --executor ray --ray-address HEAD:6379`. Each cell is one task that
   Ray places where its CPUs (and `--gpus-per-cell` GPUs: only nodes with GPUs) are free; its
   records come back into the driver's store. If the driver dies, run the same command
   again: finished cells are skipped.
5. End each node's `ray start` when done. Worker output is not echoed to the driver; it is in
   `/tmp/ray/session_latest/logs` on each node.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import logging
import multiprocessing as mp
import os
import re
import resource
import shutil
import signal
import socket
import sys
import tempfile
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from pathlib import Path, PurePosixPath
from typing import Any

from tqdm.auto import tqdm

from icil_paper import plugins
from icil_paper.fileio import atomic_write_bytes
from icil_paper.results import RESULTS_ENV_VAR, canonical_json

EXECUTORS = ("serial", "local", "ray")
LOCAL_RAY_ATTEMPTS = 3
"""Starts of a local Ray tried before giving up (its raylet may miss Ray's start-up limit
on a busy machine)."""
FORWARDED_ENV = ("ICIL_", "MUJOCO_GL")
"""Prefixes of the driver's environment variables that every cell runs with."""
_RAY_AUTH_LOGGER = "ray._private.authentication.authentication_token_setup"
_TARGET = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")
_GB = 1024 ** 3


@dataclass(frozen=True)
class Cell:
    """One independent unit of work: `target(**kwargs)`, run in a worker."""

    key: str
    """Content key of what the cell computes (e.g. its run spec's key); unique in a grid."""
    target: str
    """The function as `"package.module:function"`, imported in the worker."""
    kwargs: Mapping[str, Any] = field(default_factory=dict, hash=False)
    """Keyword arguments of the function: plain JSON (a private copy is kept)."""
    cpus: float = 1.0
    """CPUs the cell occupies (a Ray task's `num_cpus`; budgeted by the local pool too)."""
    gpus: float = 0.0
    """GPUs the cell needs (a Ray task's `num_gpus`)."""
    label: str = ""
    """What progress and error messages call the cell; the key when empty."""
    inputs: Mapping[str, tuple[str, ...]] = field(default_factory=dict, hash=False)
    """Files the cell reads, {environment variable: paths relative to the folder it names},
    sent to a node that does not share the driver's files (`run_grid(folders=...)`)."""

    def __post_init__(self) -> None:
        if not isinstance(self.key, str) or not self.key:
            raise ValueError(f"a cell's key must be a non-empty string, got {self.key!r}")
        if not isinstance(self.target, str) or not _TARGET.match(self.target):
            raise ValueError(f"cell {self.key}: target must read 'package.module:function', "
                             f"got {self.target!r}")
        try:
            kwargs = json.loads(json.dumps(dict(self.kwargs), allow_nan=False))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"cell {self.key}: kwargs must be plain JSON ({exc})") from None
        if not self.cpus > 0 or self.gpus < 0:
            raise ValueError(f"cell {self.key}: cpus must be > 0 and gpus >= 0, got "
                             f"cpus={self.cpus}, gpus={self.gpus}")
        inputs = {str(var): tuple(str(p) for p in paths) for var, paths in self.inputs.items()}
        for var, paths in inputs.items():
            for p in paths:
                _relative(p, f"cell {self.key}: input {var}")
        object.__setattr__(self, "kwargs", kwargs)
        object.__setattr__(self, "inputs", inputs)
        object.__setattr__(self, "label", self.label or self.key)


@dataclass(frozen=True)
class CellFailure:
    """A cell that did not finish: `reason` is one line, `detail` the traceback or exit."""

    key: str
    label: str
    reason: str
    attempts: int
    detail: str = ""


class GridError(RuntimeError):
    """Some cells failed; the others finished (their results are in `results`)."""

    def __init__(self, failures: list[CellFailure], results: dict[str, Any], total: int):
        self.failures = failures
        self.results = results
        lines = [f"{len(failures)} of {total} cells failed:"]
        lines += [f"  {f.label}: {f.reason}" for f in failures]
        super().__init__("\n".join(lines))


class RayUnavailable(RuntimeError):
    """Ray is not installed, or could not be started or reached."""


def run_grid(cells: Iterable[Cell], executor: str = "local", workers: int = 2,
             ray_address: str | None = None, done: Callable[[Cell], bool] | None = None,
             retries: int = 2, progress: bool = True, threads: int | None = 1,
             folders: Mapping[str, str | Path] | None = None,
             recycle_gb: float | None = None) -> dict[str, Any]:
    """Run every cell that `done` does not call finished; return {key: what it returned}.

    Args:
        cells: the grid; keys must be unique.
        executor: "local" (spawned process pool), "ray" or "serial" (this process).
        workers: processes of the local pool; CPUs of a local Ray started here.
        ray_address: join this Ray cluster ("HEAD:6379", "auto") instead of starting one.
        done: `done(cell)` true means the cell's result is stored already: it is skipped.
        retries: runs more of a cell whose worker process died (not of one that raised).
        progress: a tqdm bar over cells.
        threads: torch intra-op threads in each cell (None: leave torch's setting).
        folders: {environment variable: the driver's folder} of every folder cells read
            and write; with executor "ray", cells then share no files with the driver
            (module docstring). The local and serial executors run in these folders.
        recycle_gb: local pool only: a worker whose resident memory after a cell is
            above this many GiB is replaced by a fresh process (None: the machine's memory
            shared by the workers and the driver, `default_recycle_gb`).

    Returns:
        The JSON results of the cells that ran, in the grid's order (skipped ones are absent).

    Raises:
        GridError: after all other cells finished, listing each failed cell.
        RayUnavailable: executor "ray" and Ray cannot be imported, started or reached.
    """
    cells = list(cells)
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; choose one of {', '.join(EXECUTORS)}")
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if not isinstance(retries, int) or retries < 0:
        raise ValueError(f"retries must be a non-negative integer, got {retries!r}")
    if recycle_gb is None:
        recycle_gb = default_recycle_gb(workers)
    if not recycle_gb > 0:
        raise ValueError(f"recycle_gb must be a positive number of GiB, got {recycle_gb!r}")
    folders = {str(var): os.path.abspath(path) for var, path in (folders or {}).items()}
    seen: set[str] = set()
    for cell in cells:
        if not isinstance(cell, Cell):
            raise TypeError(f"run_grid takes Cell objects, got {type(cell).__name__}")
        if cell.key in seen:
            raise ValueError(f"two cells have the key {cell.key!r}; a grid's keys are unique")
        seen.add(cell.key)
    todo = [c for c in cells if done is None or not done(c)]
    if not todo:
        return {}


    job = _job(threads)
    bar = tqdm(total=len(todo), desc=f"grid ({executor})", unit="cell", disable=not progress)
    tracker = _Tracker(bar)
    try:
        if executor == "serial":
            _run_serial(todo, job, tracker)
        elif executor == "local":
            _run_local(todo, job, workers, retries, tracker, recycle_gb)
        else:
            _run_ray(todo, job, workers, ray_address, retries, tracker, folders, done)
    finally:
        bar.close()
    results = {c.key: tracker.results[c.key] for c in todo if c.key in tracker.results}
    if tracker.failures:
        order = {c.key: i for i, c in enumerate(todo)}
        failures = sorted(tracker.failures, key=lambda f: order[f.key])
        raise GridError(failures, results, len(todo))
    return results


def default_recycle_gb(workers: int) -> float:
    """The resident memory (GiB) past which a local pool worker is replaced: the
    machine's physical memory in `workers + 1` equal shares (the driver, the simulators'
    own processes and the page cache take the last one). 24 GiB and 2 workers: 8 GiB."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / (workers + 1) / _GB


def resident_gb() -> float:
    """This process's resident memory now, in GiB (`/proc/self/statm`); where there is no
    `/proc` (macOS), its peak so far (`ru_maxrss`, in bytes there)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / _GB
    return pages * os.sysconf("SC_PAGE_SIZE") / _GB


# --------------------------------------------------------------------------- one cell
def _job(threads: int | None) -> dict[str, Any]:
    """What a worker needs to run a cell as the driver would: env, cwd, import path."""
    env = {k: v for k, v in os.environ.items() if k.startswith(FORWARDED_ENV)}
    path = [os.path.abspath(p or os.curdir) for p in sys.path]
    return {"env": env, "cwd": os.getcwd(), "path": [p for p in path if os.path.isdir(p)],
            "threads": threads, "plugins": plugins.named()}


def _execute(target: str, kwargs: Mapping[str, Any], job: Mapping[str, Any]) -> Any:
    """Run one cell in the current process under the driver's env, cwd and import path."""
    for p in job["path"]:  # e.g. a test folder or script folder that the driver imports from
        if p not in sys.path and os.path.isdir(p):
            sys.path.append(p)
    env_before = {k: os.environ.get(k) for k in job["env"]}
    cwd_before = os.getcwd()
    os.environ.update(job["env"])
    if os.path.isdir(job["cwd"]):
        os.chdir(job["cwd"])
    try:
        if job.get("plugins"):  # the driver's --plugin modules and files (entry points:
            plugins.load_plugins(job["plugins"])  # the registries find them on first use)
        module, _, name = target.partition(":")
        fn = getattr(importlib.import_module(module), name)
        with _torch_threads(job["threads"]):
            result = fn(**kwargs)
        return json.loads(canonical_json(result))
    finally:
        os.chdir(cwd_before)
        for k, v in env_before.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _relative(path: str, what: str) -> PurePosixPath:
    """`path` as a relative path that stays inside its folder (ValueError otherwise)."""
    rel = PurePosixPath(path)
    if rel.is_absolute() or not rel.parts or ".." in rel.parts:
        raise ValueError(f"{what}: {path!r} is not a relative path inside its folder")
    return rel


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _fetch(blob: Any) -> bytes:
    """A file's bytes: given, or from Ray's object store."""
    if isinstance(blob, bytes):
        return blob
    import ray

    return ray.get(blob)


def _execute_detached(target: str, kwargs: Mapping[str, Any], job: Mapping[str, Any],
                      inputs: list[tuple[str, str, str, Any]]) -> dict[str, Any]:
    """Run one cell in private folders on this node (module docstring, "Cells that share no
    files with the driver"): `inputs` are (variable, relative path, SHA-256, bytes or an
    object reference). Returns {"result", "files": [(variable, path, SHA-256, bytes)],
    "node"}."""
    scratch = Path(tempfile.mkdtemp(prefix="icil-cell-"))
    try:
        roots = {var: scratch / f"folder{i}" for i, var in enumerate(job["folders"])}
        given: dict[tuple[str, str], str] = {}
        for var, path, digest, blob in inputs:
            data = _fetch(blob)
            if _sha256(data) != digest:
                raise RuntimeError(f"the input {path} arrived damaged (its SHA-256 differs)")
            target_path = roots[var] / _relative(path, "input")
            target_path.parent.mkdir(parents=True, exist_ok=True)
            target_path.write_bytes(data)
            given[var, path] = digest
        for root in roots.values():
            root.mkdir(parents=True, exist_ok=True)
        (scratch / "cwd").mkdir()
        env = {**job["env"], **{var: str(root) for var, root in roots.items()}}
        result = _execute(target, kwargs, {**job, "env": env, "cwd": str(scratch / "cwd")})
        files = []
        for var, root in roots.items():
            for path in sorted(root.rglob("*")):
                rel = path.relative_to(root)
                if any(part.startswith(".") for part in rel.parts) or not path.is_file():
                    continue  # locks and temporary files stay
                data = path.read_bytes()
                digest = _sha256(data)
                if given.get((var, rel.as_posix())) != digest:
                    files.append((var, rel.as_posix(), digest, data))
        return {"result": result, "files": files, "node": _node_id()}
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _node_id() -> str | None:
    """The Ray node this process runs on (None outside Ray)."""
    ray = sys.modules.get("ray")
    if ray is None or not ray.is_initialized():
        return None
    return ray.get_runtime_context().get_node_id()


def read_inputs(cell: Cell, folders: Mapping[str, str],
                cache: dict[tuple[str, str], tuple[str, bytes] | None] | None = None
                ) -> list[tuple[str, str, str, bytes]]:
    """The files `cell.inputs` names that exist in the driver's `folders`, with their SHA-256
    (`cache` keeps each file read once over a grid: a data set many cells read)."""
    cache = {} if cache is None else cache
    found = []
    for var, paths in cell.inputs.items():
        if var not in folders:
            raise ValueError(f"cell {cell.label}: input folder {var} is not one of the grid's "
                             f"folders ({', '.join(folders)})")
        for path in paths:
            if (var, path) not in cache:
                try:
                    data = (Path(folders[var]) / _relative(path, "input")).read_bytes()
                except FileNotFoundError:  # not made yet: the cell makes it
                    cache[var, path] = None
                else:
                    cache[var, path] = (_sha256(data), data)
            if cache[var, path] is not None:
                found.append((var, path, *cache[var, path]))
    return found


def install_files(files: list[tuple[str, str, str, bytes]], folders: Mapping[str, str],
                  sent: Iterable[tuple[str, str, str, Any]] = ()) -> int:
    """Write the files a detached cell returned into the driver's `folders`; return how many.

    Everything is checked before anything is written: each file's SHA-256, its path (inside
    its folder), and that each record among them (a JSON file in the `ICIL_RESULTS` folder)
    that names files came back with files of those names and digests (or was sent them:
    `sent`, the cell's inputs). Then files are written atomically, records last. ValueError
    names the first problem.
    """
    checked = []
    shipped = {(PurePosixPath(path).name, digest) for _, path, digest, _ in sent}
    for var, path, digest, data in files:
        if var not in folders:
            raise ValueError(f"a file came back for the folder {var}, which is not one of the "
                             f"grid's ({', '.join(folders)})")
        rel = _relative(path, f"a file returned for {var}")
        if _sha256(data) != digest:
            raise ValueError(f"{path} came back damaged (its SHA-256 differs from the node's)")
        checked.append((var, Path(folders[var]) / rel, data))
        shipped.add((rel.name, digest))
    for var, target, data in checked:
        if var != RESULTS_ENV_VAR or target.suffix != ".json":
            continue
        try:
            named = json.loads(data).get("files") or {}
        except (ValueError, AttributeError):
            raise ValueError(f"the record {target.name} came back unreadable") from None
        for name, digest in named.items():
            if (name, digest) not in shipped:
                raise ValueError(f"the record {target.name} names {name} (SHA-256 "
                                 f"{str(digest)[:12]}..), which did not come back with it")
    checked.sort(key=lambda f: f[0] == RESULTS_ENV_VAR)  # records last: never one without its files
    for _, target, data in checked:
        atomic_write_bytes(target, data)
    return len(checked)


@contextmanager
def _torch_threads(n: int | None) -> Iterator[None]:
    """torch on `n` intra-op threads for a block, where torch is loaded (no import here)."""
    torch = sys.modules.get("torch")
    if n is None or torch is None:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__


class _Tracker:
    """Collects results and failures and moves the progress bar."""

    def __init__(self, bar: Any):
        self.bar = bar
        self.results: dict[str, Any] = {}
        self.failures: list[CellFailure] = []

    def started(self) -> None:
        """Workers are up: the bar's clock starts now, so its rate is the cells' own."""
        self.bar.reset()

    def ok(self, cell: Cell, result: Any) -> None:
        self.results[cell.key] = result
        self.bar.set_postfix_str(cell.label[-40:], refresh=False)
        self.bar.update()

    def failed(self, cell: Cell, reason: str, detail: str, attempts: int) -> None:
        self.failures.append(CellFailure(cell.key, cell.label, reason, attempts, detail))
        self.bar.write(f"failed: {cell.label}: {reason}")
        self.bar.update()

    def retry(self, cell: Cell, why: str, attempt: int) -> None:
        self.bar.write(f"retrying {cell.label} (attempt {attempt}): {why}")


# --------------------------------------------------------------------------- serial
def _run_serial(todo: list[Cell], job: dict[str, Any], tracker: _Tracker) -> None:
    for cell in todo:
        try:
            result = _execute(cell.target, cell.kwargs, job)
        except Exception as exc:  # a failing cell must not stop the others
            tracker.failed(cell, _one_line(exc), traceback.format_exc(), 1)
        else:
            tracker.ok(cell, result)


# --------------------------------------------------------------------------- local pool
def _worker_main(conn: Any, threads: int | None) -> None:
    """A pool process: run the cells sent over `conn` until told to stop (None)."""
    if threads is not None:  # torch imported later by a cell starts with this many threads
        os.environ["OMP_NUM_THREADS"] = str(threads)
    try:
        conn.send(("ready",))
        while True:
            try:
                message = conn.recv()
            except EOFError:
                return
            if message is None:
                return
            target, kwargs, job = message
            try:
                conn.send(("ok", _execute(target, kwargs, job), resident_gb()))
            except Exception as exc:
                conn.send(("error", _one_line(exc), traceback.format_exc()))
    except KeyboardInterrupt:  # Ctrl-C reaches the whole process group; the driver reports
        return


class _Worker:
    """One spawned pool process and the cell it is running (None: idle)."""

    def __init__(self, ctx: Any, threads: int | None):
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_main, args=(child, threads),
                                   name="icil-grid-worker")  # not daemonic: cells may fork
        self.process.start()
        child.close()
        self.cell: Cell | None = None

    def wait_ready(self) -> None:
        """Block until the process is up; raise if it died on the way (not a cell's fault)."""
        wait([self.conn, self.process.sentinel])
        if self.receive() != ("ready",):
            why = self.exit_reason()
            self.stop()
            raise RuntimeError(
                f"a grid worker process {why} before it could run a cell (its error is "
                "printed above). Worker processes are spawned and import the main module: "
                "a script that runs a grid on the local executor must do so under "
                "`if __name__ == '__main__':`.")

    def start(self, cell: Cell, job: dict[str, Any]) -> None:
        self.cell = cell
        self.conn.send((cell.target, cell.kwargs, job))

    def receive(self) -> tuple | None:
        """The worker's answer, or None when the process died without one."""
        try:
            if self.conn.poll():
                return self.conn.recv()
        except (EOFError, OSError):
            pass
        return None

    def exit_reason(self) -> str:
        self.process.join(timeout=5)
        code = self.process.exitcode
        if code is None:
            return "its pipe closed"
        if code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        return f"exited with code {code}"

    def stop(self) -> None:
        if self.process.is_alive() and self.cell is None:
            try:
                self.conn.send(None)
            except OSError:
                pass
            self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


def _run_local(todo: list[Cell], job: dict[str, Any], workers: int, retries: int,
               tracker: _Tracker, recycle_gb: float) -> None:
    ctx = mp.get_context("spawn")
    pending = deque(todo)
    attempts = dict.fromkeys((c.key for c in todo), 0)
    slots: list[_Worker | None] = [None] * min(workers, len(todo))
    try:
        for i in range(len(slots)):  # start together, then wait for each
            slots[i] = _Worker(ctx, job["threads"])
        for w in slots:
            w.wait_ready()
        tracker.started()
        while True:
            running = [w for w in slots if w is not None and w.cell is not None]
            free_cpus = workers - sum(w.cell.cpus for w in running)
            for i, w in enumerate(slots):
                if w is not None and w.cell is not None:
                    continue
                # first cell in order that fits; a cell larger than the budget runs alone
                cell = next((c for c in pending if c.cpus <= free_cpus or not running), None)
                if cell is None:
                    break
                pending.remove(cell)
                if w is None:  # its process died in a cell: a fresh one
                    w = slots[i] = _Worker(ctx, job["threads"])
                    w.wait_ready()
                attempts[cell.key] += 1
                w.start(cell, job)
                running.append(w)
                free_cpus -= cell.cpus
            if not running:
                return
            ready = set(wait([w.conn for w in running] + [w.process.sentinel for w in running]))
            for w in running:
                if w.conn not in ready and w.process.sentinel not in ready:
                    continue
                cell, answer = w.cell, w.receive()
                w.cell = None
                n = attempts[cell.key]
                if answer is None:  # the process died in the cell: retry on a fresh one
                    why = w.exit_reason()
                    w.stop()
                    slots[slots.index(w)] = None
                    if n <= retries:
                        tracker.retry(cell, f"its worker process {why}", n + 1)
                        pending.appendleft(cell)
                    else:
                        tracker.failed(cell, f"the worker process {why} (in each of {n} "
                                       "attempts)", why, n)
                elif answer[0] == "ok":
                    tracker.ok(cell, answer[1])
                    if answer[2] > recycle_gb:  # its next cell starts on a fresh process
                        w.stop()
                        slots[slots.index(w)] = None
                else:
                    tracker.failed(cell, answer[1], answer[2], n)
    finally:
        for w in slots:
            if w is not None:
                w.stop()


# --------------------------------------------------------------------------- Ray
def connect_ray(workers: int = 2, address: str | None = None) -> bool:
    """Join the Ray cluster at `address`, or start a quiet local one with `workers` CPUs.

    Returns True when this call connected (the caller then calls `ray.shutdown()`), False
    when a Ray session was already open. No dashboard, no usage statistics, worker output
    stays in Ray's log files.
    """
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
    quiet = {"log_to_driver": False, "logging_level": logging.WARNING}
    # token authentication is on for a new local Ray (Ray's default) and wherever a token
    # is found (as `ray start` does it); Ray's notice about that says nothing to act on
    logging.getLogger(_RAY_AUTH_LOGGER).setLevel(logging.ERROR)
    # A local Ray gives its raylet a fixed 30 s to come up; on a loaded 2-core machine it
    # can take longer, so a local start is tried again before giving up.
    attempts = 1 if address else LOCAL_RAY_ATTEMPTS
    for attempt in range(1, attempts + 1):
        try:
            if address:
                _use_ray_token_if_present()
                ray.init(address=address, **quiet)
            else:
                ray.init(address="local", num_cpus=workers, include_dashboard=False, **quiet)
            return True
        except Exception as exc:
            if ray.is_initialized():
                ray.shutdown()
            if attempt < attempts:
                continue
            where = f"the Ray cluster at {address}" if address else "a local Ray"
            tried = f" ({attempts} attempts)" if attempts > 1 else ""
            raise RayUnavailable(f"could not start or reach {where}{tried}: "
                                 f"{_one_line(exc)}") from exc
    return True


def check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """A `HOST:PORT` address whose port does not answer fails at once with the fix, instead
    of Ray's own wait for its control store (a minute of retries and log lines)."""
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


def _use_ray_token_if_present() -> None:
    """Send the Ray token (`~/.ray/auth_token`, `RAY_AUTH_TOKEN`) when joining a cluster.

    `ray start` turns token authentication on when it finds a token, but a driver's
    `ray.init(address=...)` does not, and the cluster then refuses it. This applies `ray
    start`'s rule (an explicit `RAY_AUTH_MODE` wins) through Ray's own helper.
    """
    try:
        from ray._private.authentication.authentication_token_setup import (
            maybe_enable_token_auth_if_token_available,
        )
    except ImportError:  # another Ray version: its own default applies
        return
    maybe_enable_token_auth_if_token_available(warn_if_disabled=False)


def _run_ray(todo: list[Cell], job: dict[str, Any], workers: int, ray_address: str | None,
             retries: int, tracker: _Tracker, folders: Mapping[str, str] | None = None,
             done: Callable[[Cell], bool] | None = None) -> None:
    connected = connect_ray(workers, ray_address)
    import ray
    from ray.exceptions import RayTaskError

    refs: dict[Any, Cell] = {}
    sent: dict[str, list] = {}
    nodes: dict[str | None, int] = {}
    tracker.started()
    try:
        total = ray.cluster_resources()
        for cell in todo:  # a task no node can hold would wait forever
            if ray_address is None and (cell.cpus > total.get("CPU", 0)
                                        or cell.gpus > total.get("GPU", 0)):
                raise ValueError(f"cell {cell.label} needs {cell.cpus} CPUs and {cell.gpus} "
                                 f"GPUs; this Ray has {total.get('CPU', 0)} and "
                                 f"{total.get('GPU', 0)}")
        if folders:
            task = ray.remote(_execute_detached)
            job = {**job, "folders": list(folders)}
            stored: dict[tuple[str, str, str], Any] = {}  # one object per distinct file
            read: dict[tuple[str, str], Any] = {}
        else:
            task = ray.remote(_execute)
        for cell in todo:
            options = task.options(num_cpus=cell.cpus, num_gpus=cell.gpus, max_retries=retries,
                                   retry_exceptions=False, name=cell.label[:100])
            if folders:
                inputs = read_inputs(cell, folders, read)
                sent[cell.key] = inputs
                shipped = []
                for var, path, digest, data in inputs:
                    if (var, path, digest) not in stored:
                        stored[var, path, digest] = ray.put(data)
                    shipped.append((var, path, digest, stored[var, path, digest]))
                ref = options.remote(cell.target, cell.kwargs, job, shipped)
            else:
                ref = options.remote(cell.target, cell.kwargs, job)
            refs[ref] = cell
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                cell = refs.pop(ref)
                try:
                    result = ray.get(ref)
                except RayTaskError as exc:  # the function raised
                    cause = exc.cause if isinstance(exc.cause, BaseException) else exc
                    tracker.failed(cell, _one_line(cause), str(exc), 1)
                    continue
                except ray.exceptions.RayError as exc:  # the worker (or its node) died
                    tracker.failed(cell, f"the worker died in each of {retries + 1} attempts "
                                   f"({type(exc).__name__})", str(exc), retries + 1)
                    continue
                if folders:
                    try:
                        install_files(result["files"], folders, sent.pop(cell.key))
                    except (ValueError, OSError) as exc:
                        tracker.failed(cell, f"its files did not come back whole: {exc}",
                                       traceback.format_exc(), 1)
                        continue
                    if done is not None and not done(cell):
                        tracker.failed(cell, "its node finished it, but its records are not "
                                       "all in the driver's store", "", 1)
                        continue
                    nodes[result["node"]] = nodes.get(result["node"], 0) + 1
                    result = result["result"]
                tracker.ok(cell, result)
        if nodes:
            tracker.bar.write(_placement(nodes, ray.nodes()))
    finally:
        for ref in refs:  # left only when the driver stops early (Ctrl-C, an error)
            ray.cancel(ref, force=True)
        if connected:
            ray.shutdown()


def _placement(counts: Mapping[str | None, int], nodes: list[dict[str, Any]]) -> str:
    """One line: how many cells ran on each node, with its address and GPUs."""
    info = {n.get("NodeID"): n for n in nodes}
    parts = []
    for node, n in sorted(counts.items(), key=lambda item: -item[1]):
        about = info.get(node, {})
        gpus = about.get("Resources", {}).get("GPU", 0)
        parts.append(f"{str(node)[:12]} ({about.get('NodeManagerAddress', '?')}, "
                     f"{gpus:g} GPUs): {n}")
    return "cells by node: " + "; ".join(parts)
