"""`icil-paper reproduce`: run every experiment of a preset, in order, into the results store.

Each stage (`STAGES`, in order) is a function `run(preset, store, force) -> None` that writes
its records through `ResultsStore.run`, so a finished stage is a cheap load and a killed run
resumes where it stopped; the notebooks call the same functions, and then only load.

The table stages fan their cells out over `--workers` processes or a Ray cluster
(`--executor ray`); a block of consecutive table stages is computed together (`TOGETHER`), so
a shared policy is trained once. A preset with seeds in stages (`tables.seed_stages`) registers
its design first and runs its table stages look by look (`icil_paper.planning.staged`).
"""

from __future__ import annotations

import itertools
import sys
import time

from tqdm.auto import tqdm

from icil_paper.book.own_tokenizer import own_tokenizer_study
from icil_paper.book.studies import (
    demo_stage,
    expert_study,
    lipschitz_study,
    showcase_study,
    tokenizer_study,
)
from icil_paper.commands import (
    Parser,
    add_executor_arguments,
    add_preset_arguments,
    check_executor_arguments,
    preset_from_args,
)
from icil_paper.config import Preset
from icil_paper.data.generate import check_data_folder, check_tasks, demo_path, preset_tasks
from icil_paper.fileio import check_env_folder
from icil_paper.paper import check_row_seeds, run_tables, write_ledger
from icil_paper.planning.staged import staged_preset
from icil_paper.registry import check_name
from icil_paper.results import RESULTS_ENV_VAR, ResultsStore
from icil_paper.seeding import seed_everything
from icil_paper.setup.envcheck import environment_report
from icil_paper.stages import GRID, TABLE_STAGES, Stage
from icil_paper.tables.cells import check_reachable
from icil_paper.train.rundir import RUNS_ENV_VAR


def record_environment(preset: Preset, store: ResultsStore, force: bool) -> None:
    """Store the environment report of this machine (always refreshed)."""
    def compute():
        report = environment_report(preset.name)
        return {"checks": {c["name"]: c["ok"] for c in report["checks"]},
                "device": (report.get("torch") or {}).get("device", "cpu")}

    store.run("environment", "machine", {"preset": preset.name}, compute, seed=preset.seed,
              force=True)


TOGETHER: list[list[str]] = []
"""The tables of this invocation's table stages, by block of consecutive table stages (set by
`run_stages`): the first stage of a block computes the cells of all of its tables."""


def table_blocks(names: list[str]) -> list[list[str]]:
    """The table ids of `names` in blocks of consecutive table stages:
    ["table-icrt", "lipschitz", "table-I", "table-V"] -> [["icrt"], ["I", "V"]]."""
    runs = itertools.groupby(names, key=lambda name: name.startswith("table-"))
    return [[name.removeprefix("table-") for name in run] for is_table, run in runs if is_table]


def _table(table_id: str) -> Stage:
    def stage(preset: Preset, store: ResultsStore, force: bool) -> None:
        if force:
            raise ValueError("--force does not apply to the table stages: delete the records "
                             f"under {store.dir} to recompute them")
        block = next((b for b in TOGETHER if table_id in b), [table_id])
        current, _ = staged_preset(preset, store, write=True)  # registers the design first
        while True:  # one pass without stages; with them, until no row goes on
            run_tables(current, block, **GRID)
            after, looks = staged_preset(preset, store, write=True)
            if after == current:
                break
            tqdm.write(f"   look at {looks[-1].seeds} seeds a row: "
                       f"{len(looks[-1].going_on)} rows go on")
            current = after
    stage.__doc__ = f"Compute every missing cell of table {table_id}."
    _, what, chapter = next(t for t in TABLE_STAGES if t[0] == table_id)
    return Stage(f"table-{table_id}", f"{what} (chapter {chapter})", stage)


def claims_stage(preset: Preset, store: ResultsStore, force: bool) -> None:
    """Write results/<preset>/claims.json from the tables' records."""
    write_ledger(staged_preset(preset, store)[0], store)


STAGES: tuple[Stage, ...] = (
    Stage("environment", "record the packages, hardware and simulator checks",
          record_environment),
    Stage("demos", "generate every data set of the preset: all tasks, both sources (chapter 04)",
          demo_stage),
    Stage("experts", "measure every expert on data.expert_seeds random scenes (chapter 04)",
          expert_study),
    Stage("showcase", "render and record one demonstration of every task (chapter 04)",
          showcase_study),
    _table("icrt"),
    Stage("lipschitz", "Lipschitz bounds vs empirical constants of trained encoders (chapter 03)",
          lipschitz_study),
    Stage("tokenizers", "train every action tokenizer alone and score it (chapter 05)",
          tokenizer_study),
    *(_table(t) for t, _, _ in TABLE_STAGES[1:]),
    Stage("own-tokenizer", "a tokenizer of one file, loaded as a plugin, against LipVQ-VAE "
          "on Table I's protocol (chapter 14)", own_tokenizer_study),
    Stage("claims", "the claims ledger: every claim with its verdict (chapter 00)", claims_stage),
)


def run_stages(preset: Preset, stages: list[str] | None = None, force: bool = False) -> dict:
    """Run the named stages (default all) and return {stage: seconds}."""
    chosen = [s for s in STAGES if stages is None or s.name in stages]
    for name in stages or []:
        check_name("stage", name, [s.name for s in STAGES])
    store = ResultsStore(preset.name)
    TOGETHER[:] = table_blocks([s.name for s in chosen])
    timings = {}
    for stage in tqdm(chosen, desc=f"reproduce [{preset.name}]", unit="stage"):
        tqdm.write(f"== {stage.name}: {stage.description}")
        start = time.perf_counter()
        seed_everything(preset.seed)
        stage.run(preset, store, force)
        timings[stage.name] = time.perf_counter() - start
        tqdm.write(f"   {stage.name} done in {timings[stage.name]:.1f} s")
    return timings


def check_outputs(preset: Preset) -> None:
    """Refuse, before any stage, output folders this process cannot write to (the data folder
    only when a data set of the preset is missing)."""
    check_env_folder(RESULTS_ENV_VAR, "results")
    check_env_folder(RUNS_ENV_VAR, "runs")
    tasks = preset_tasks(preset)
    if not all(demo_path(preset, t, s).exists() for t in tasks for s in preset.data.sources):
        check_data_folder(preset)


def main(argv: list[str] | None = None) -> int:
    parser = Parser(prog="icil-paper reproduce", description=__doc__.split("\n\n")[0])
    add_preset_arguments(parser)
    parser.add_argument("--stages", nargs="+", default=None,
                        help=f"run only these stages ({', '.join(s.name for s in STAGES)})")
    parser.add_argument("--force", action="store_true", help="recompute stored results")
    add_executor_arguments(parser)
    args = parser.parse_args(argv)
    check_executor_arguments(parser, args)
    preset = preset_from_args(args)
    check_tasks(preset)
    check_row_seeds(preset)
    for name in args.stages or []:
        check_name("stage", name, [s.name for s in STAGES])
    check_outputs(preset)
    if args.executor == "ray" and args.ray_address:
        check_reachable(args.ray_address)  # before any stage, not after the data sets
    GRID.update(executor=args.executor, workers=args.workers, ray_address=args.ray_address,
                gpus_per_cell=args.gpus_per_cell)
    timings = run_stages(preset, args.stages, args.force)
    total = sum(timings.values())
    print(f"reproduce [{preset.name}]: {len(timings)} stages in {total:.1f} s; "
          f"results in {ResultsStore(preset.name).dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
