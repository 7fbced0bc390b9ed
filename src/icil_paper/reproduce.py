"""`icil-paper reproduce`: run every experiment of a preset, in order, into the results store.

Each stage is a library function `stage(preset, store, force) -> None` that writes its
records through `ResultsStore.run`, so a stage that already has its results is a cheap
load, and a run killed half-way resumes where it stopped. The book's notebooks call the
same functions, so after `reproduce` they only load. `make reproduce` then builds the book.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from dataclasses import dataclass

from icil_paper.config import PRESET_NAMES, Preset, active_preset_name, get_preset
from icil_paper.results import ResultsStore
from icil_paper.seeding import seed_everything


@dataclass(frozen=True)
class Stage:
    """One step of the reproduction."""

    name: str
    """Short name, usable with --stages."""
    description: str
    """What it computes."""
    target: str
    """"module:function" called as function(preset, store, force)."""


STAGES: tuple[Stage, ...] = (
    Stage("environment", "record the packages, hardware and simulator checks",
          "icil_paper.reproduce:record_environment"),
    Stage("demos", "generate every data set of the preset: all tasks, both sources (chapter 03)",
          "icil_paper.studies:demo_stage"),
    Stage("experts", "measure every expert on data.expert_seeds random scenes (chapter 03)",
          "icil_paper.studies:expert_study"),
    Stage("showcase", "render and record one demonstration of every task (chapter 03)",
          "icil_paper.studies:showcase_study"),
    Stage("icrt", "train a small ICRT + LipVQ-VAE and roll it out from prompts (chapter 01)",
          "icil_paper.studies:icrt_rollout_study"),
    Stage("lipschitz", "Lipschitz bounds vs empirical constants of trained encoders (chapter 02)",
          "icil_paper.studies:lipschitz_study"),
    Stage("tokenizers", "train every action tokenizer alone and score it (chapter 04)",
          "icil_paper.studies:tokenizer_study"),
)


def record_environment(preset: Preset, store: ResultsStore, force: bool) -> None:
    """Store the environment report of this machine (always refreshed)."""
    from icil_paper.envcheck import environment_report

    def compute():
        report = environment_report()
        return {"checks": {c["name"]: c["ok"] for c in report["checks"]},
                "device": (report.get("torch") or {}).get("device", "cpu")}

    store.run("environment", "machine", {"preset": preset.name}, compute, seed=preset.seed,
              force=True)


def run_stages(preset: Preset, stages: list[str] | None = None, force: bool = False) -> dict:
    """Run the named stages (default all) and return {stage: seconds}."""
    from tqdm.auto import tqdm

    names = [s.name for s in STAGES]
    chosen = [s for s in STAGES if stages is None or s.name in stages]
    for name in stages or []:
        if name not in names:
            from icil_paper.registry import check_name

            check_name("stage", name, names)
    store = ResultsStore(preset.name)
    timings = {}
    for stage in tqdm(chosen, desc=f"reproduce [{preset.name}]", unit="stage"):
        tqdm.write(f"== {stage.name}: {stage.description}")
        module, _, function = stage.target.partition(":")
        start = time.perf_counter()
        seed_everything(preset.seed)
        getattr(importlib.import_module(module), function)(preset, store, force)
        timings[stage.name] = time.perf_counter() - start
        tqdm.write(f"   {stage.name} done in {timings[stage.name]:.1f} s")
    return timings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="icil-paper reproduce", description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", choices=PRESET_NAMES, default=None,
                        help="preset (default: $ICIL_PRESET or small)")
    parser.add_argument("--seed", type=int, default=None, help="override the preset's seed")
    parser.add_argument("--stages", nargs="+", default=None,
                        help=f"run only these stages ({', '.join(s.name for s in STAGES)})")
    parser.add_argument("--force", action="store_true", help="recompute stored results")
    args = parser.parse_args(argv)
    preset = get_preset(active_preset_name(args.preset), seed=args.seed)
    timings = run_stages(preset, args.stages, args.force)
    total = sum(timings.values())
    print(f"reproduce [{preset.name}]: {len(timings)} stages in {total:.1f} s; "
          f"results in {ResultsStore(preset.name).dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
