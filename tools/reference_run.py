"""The reference run in the background, from a frozen worktree, committed as it finishes.

    python -m tools.reference_run start --commit 49b6dde   # worktree, folders, background run
    python -m tools.reference_run sync                     # commit the records finished so far
    python -m tools.reference_run status                   # the run's process and records

`start` checks out COMMIT as a detached worktree beside the repository (`../icil-reference-run`
unless `--worktree`), so that no change to the code in this checkout moves a run key while
the run goes on, and runs `icil-paper reproduce --preset reference --workers 2` there in the
background (its log in `reference-run.log` of its folders). The run's results, runs and data
folders are its own (`--folders`, default `../icil-reference-run-files`); on a machine where
they are missing, the results folder starts from the records committed under
`results/rerun/reference/`, so the run resumes where the last sitting stopped (data sets are
made again from their seeds). `sync` copies every finished record (no temporary, lock or
recording file) into `results/rerun/reference/`, writes its `cost.json` and commits them.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RERUN = ROOT / "results" / "rerun" / "reference"
"""Where the run's records are committed while it goes on."""
SKIPPED_SUFFIXES = (".tmp", ".lock", ".rrd", ".png")
"""Files `sync` never copies: unfinished writes, locks, and what git ignores in results."""


def finished_files(store: Path) -> list[Path]:
    """The files of a results folder that `sync` commits, relative to it, sorted."""
    return sorted(p.relative_to(store) for p in store.rglob("*")
                  if p.is_file() and not p.name.startswith(".")
                  and not p.name.endswith(SKIPPED_SUFFIXES))


def copy_finished(store: Path, target: Path) -> int:
    """Copy the finished files of `store` that `target` lacks or holds otherwise; returns
    how many were copied."""
    copied = 0
    for rel in finished_files(store):
        source, dest = store / rel, target / rel
        if dest.exists() and dest.read_bytes() == source.read_bytes():
            continue
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = dest.with_name(f".{dest.name}.tmp")
        shutil.copy2(source, tmp)
        os.replace(tmp, dest)
        copied += 1
    return copied


def _env(folders: Path) -> dict[str, str]:
    return {**os.environ, "ICIL_RESULTS": str(folders / "results"),
            "ICIL_RUNS": str(folders / "runs"), "ICIL_DATA": str(folders / "data"),
            "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONUNBUFFERED": "1"}


def _git(*args: str, cwd: Path = ROOT) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                          text=True).stdout.strip()


def _running(folders: Path) -> int | None:
    """The process group of the run started from `folders`, while it runs."""
    pid_file = folders / "reference-run.pid"
    pid = int(pid_file.read_text()) if pid_file.exists() else None
    return pid if pid is not None and Path(f"/proc/{pid}").exists() else None


def start(commit: str, worktree: Path, folders: Path) -> None:
    if (pid := _running(folders)) is not None:
        sys.exit(f"the reference run is already running (process group {pid}); "
                 "`python -m tools.reference_run status` shows it")
    if not worktree.exists():
        _git("worktree", "add", "--detach", str(worktree), commit)
    head = _git("rev-parse", "HEAD", cwd=worktree)
    if not head.startswith(_git("rev-parse", commit)):
        sys.exit(f"{worktree} is at {head[:7]}, not {commit}: a run resumes from the commit "
                 "it started at (remove the worktree to start another)")
    store = folders / "results" / "reference"
    if not store.exists() and RERUN.exists():
        print(f"{copy_finished(RERUN, store)} committed records copied into {store}")
    log = folders / "reference-run.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    env = {**_env(folders), "PYTHONPATH": str(worktree / "src")}
    with open(log, "a") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "icil_paper.cli", "reproduce", "--preset", "reference",
             "--workers", "2"], cwd=worktree, env=env, stdout=out, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL, start_new_session=True)
    (folders / "reference-run.pid").write_text(str(process.pid))
    print(f"the reference run is running from {head[:7]} (process group {process.pid}); "
          f"log: {log}")


def sync(folders: Path) -> None:
    store = folders / "results" / "reference"
    if not store.exists():
        sys.exit(f"{store} does not exist: start the run first (python -m tools.reference_run "
                 "start --commit COMMIT)")
    copied = copy_finished(store, RERUN)
    env = {**_env(folders), "ICIL_RESULTS": str(RERUN.parent), "PYTHONPATH": str(ROOT / "src")}
    subprocess.run([sys.executable, "-m", "icil_paper.planning.cost", "--preset", "reference"],
                   cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL)
    _git("add", str(RERUN))
    if subprocess.run(["git", "diff", "--cached", "--quiet", "--", str(RERUN)], cwd=ROOT).returncode:
        records = sum(1 for p in finished_files(RERUN) if p.suffix == ".json")
        commit = _git("log", "-1", "--format=%h", cwd=ROOT)
        _git("commit", "-q", "-m", f"Reference run on Meta-World, in progress: {records} records "
             "committed", "--", str(RERUN))
        print(f"{copied} files copied; {records} records committed (after {commit})")
    else:
        print("nothing new to commit")


def status(folders: Path) -> None:
    pid = _running(folders)
    store = folders / "results" / "reference"
    records = sum(1 for p in finished_files(store) if p.suffix == ".json") if store.exists() else 0
    committed = sum(1 for p in finished_files(RERUN) if p.suffix == ".json") if RERUN.exists() else 0
    print(f"{'running, process group ' + str(pid) if pid else 'not running'}; {records} records in "
          f"{store}, {committed} committed under {RERUN.relative_to(ROOT)}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.reference_run",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("start", "sync", "status"))
    parser.add_argument("--commit", help="with start: the commit the run runs from")
    parser.add_argument("--worktree", type=Path, default=ROOT.parent / "icil-reference-run")
    parser.add_argument("--folders", type=Path, default=ROOT.parent / "icil-reference-run-files",
                        help="the run's results, runs and data folders")
    args = parser.parse_args(argv)
    if args.action == "start":
        if not args.commit:
            parser.error("start needs --commit: the commit whose design the run registered")
        start(args.commit, args.worktree, args.folders)
    elif args.action == "sync":
        sync(args.folders)
    else:
        status(args.folders)


if __name__ == "__main__":
    main()
