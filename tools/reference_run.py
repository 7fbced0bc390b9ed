"""The reference run in the background, from a frozen worktree, committed as it finishes.

    python -m tools.reference_run start --commit 49b6dde   # worktree, folders, background run
    python -m tools.reference_run sync                     # commit the records finished so far
    python -m tools.reference_run status                   # the run's process and records
    python -m tools.reference_run finish                   # once every cell has run: the
                                                           # run's records become results/reference/

`start` checks out COMMIT as a detached worktree beside the repository (`../icil-reference-run`
unless `--worktree`), so that no change to the code in this checkout moves a run key while
the run goes on, and runs `icil-paper reproduce --preset reference --workers 2` there in the
background (its log in `reference-run.log` of its folders). The run's results, runs and data
folders are its own (`--folders`, default `../icil-reference-run-files`); on a machine where
they are missing, the results folder starts from the records committed under
`results/rerun/reference/`, so the run resumes where the last sitting stopped (data sets are
made again from their seeds). `sync` copies every finished record (no temporary, lock or
recording file) into `results/rerun/reference/`, writes its `cost.json` and commits them.

`finish`, once the run has stopped with every planned cell of its last stage finished, makes
its records the reference run's: the kitchen suite's run (the protocol before Meta-World)
keeps its ledger, cost and design record under `results/reference/older-code/kitchen/`, the
run's records are copied into `results/reference/`, every record the current code no longer
computes moves to `older-code/records/` (`icil-paper tables --retire-stale`), the ledger,
`cost.json` and the plan for the undecided claims (`icil-paper plan`) are computed from the
new records, and `results/rerun/` goes; one commit.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from icil_paper.book.report import run_progress
from icil_paper.fileio import atomic_write_json

ROOT = Path(__file__).resolve().parents[1]
RERUN = ROOT / "results" / "rerun" / "reference"
"""Where the run's records are committed while it goes on."""
REFERENCE = ROOT / "results" / "reference"
"""The committed reference run, which the finished run replaces."""
KITCHEN = "older-code/kitchen"
"""Under `REFERENCE`: the kitchen suite's run, kept as a record of that protocol."""
KITCHEN_FILES = ("claims.json", "cost.json", "design.json")
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


def unfinished(cost_file: Path) -> str | None:
    """Why the run whose `cost.json` is `cost_file` has not finished, or None when every
    planned cell of its last stage has its records and no stage follows."""
    progress = run_progress(cost_file)
    if progress is None:
        return f"{cost_file} plans no cells yet"
    if progress["finished"] < progress["planned"]:
        return f"{progress['finished']} of its {progress['planned']} planned cells have finished"
    if progress["more_stages"]:
        return "its last look sends rows on to another stage"
    return None


def archive_kitchen(reference: Path, commit: str) -> list[str]:
    """Move the kitchen suite's ledger, cost and design record from `reference` to `KITCHEN`,
    the ledger labelled with `commit`, the one that computed it; returns the files moved
    (none when `reference` holds no kitchen run)."""
    design = reference / "design.json"
    if not design.exists() or json.loads(design.read_text()).get("protocol") != "kitchen":
        return []
    target = reference / KITCHEN
    target.mkdir(parents=True, exist_ok=True)
    claims = json.loads((reference / "claims.json").read_text())
    claims["made_by"] = {"commit": commit or "unknown", "why_kept": (
        "the reference run on the robosuite kitchen suite that stood in for RoboCasa before "
        "Meta-World, under the older design (Holm's correction over every claim alike); kept "
        "as a record of that protocol beside the run on Meta-World that replaced it")}
    atomic_write_json(target / "claims.json", claims)
    (reference / "claims.json").unlink()
    for name in KITCHEN_FILES[1:]:
        os.replace(reference / name, target / name)
    return [f"{KITCHEN}/{name}" for name in KITCHEN_FILES]


def finish(folders: Path) -> None:
    if (pid := _running(folders)) is not None:
        sys.exit(f"the reference run is still running (process group {pid}): finish it first")
    sync(folders)
    if (why := unfinished(RERUN / "cost.json")) is not None:
        sys.exit(f"the reference run has not finished: {why}; resume it with `python -m "
                 "tools.reference_run start --commit COMMIT`")
    moved = archive_kitchen(REFERENCE, _git("log", "-1", "--format=%H", "--",
                                            str(REFERENCE / "claims.json")))
    print(f"the kitchen run's {', '.join(moved) or 'files: none (already kept)'}")
    print(f"{copy_finished(RERUN, REFERENCE)} records copied into {REFERENCE}")
    env = {**os.environ, "ICIL_RESULTS": str(REFERENCE.parent), "PYTHONPATH": str(ROOT / "src")}
    for command in (["-m", "icil_paper.cli", "tables", "--preset", "reference", "--retire-stale"],
                    ["-m", "icil_paper.cli", "reproduce", "--preset", "reference", "--stages",
                     "claims"],
                    ["-m", "icil_paper.planning.cost", "--preset", "reference"],
                    ["-m", "icil_paper.cli", "plan", "--preset", "reference"]):
        subprocess.run([sys.executable, *command], cwd=ROOT, env=env, check=True)
    _git("rm", "-r", "-q", str(RERUN.parent))
    _git("add", "-A", str(REFERENCE))
    _git("commit", "-q", "-m", "Reference run on Meta-World finished: its records are the "
         "reference run's, the kitchen run's ledger, cost and design kept under older-code/kitchen/")
    print("committed; the book and README now read the finished run")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m tools.reference_run",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("start", "sync", "status", "finish"))
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
    elif args.action == "finish":
        finish(args.folders)
    else:
        status(args.folders)


if __name__ == "__main__":
    main()
