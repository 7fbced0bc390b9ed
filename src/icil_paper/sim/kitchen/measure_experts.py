"""Measure the kitchen and Kinova experts over random seeds and record the rates.

    python -m icil_paper.sim.kitchen.measure_experts --seeds 50

Runs the project's expert measurement (`icil_paper.sim.measure_experts`: expert episodes,
open-loop replays of their actions, `human`-source episodes) for the `kitchen` suite and the
`kinova` suite, writing `results/experts/kitchen.json` and `results/experts/kinova.json`
atomically, then prints one table of both. The suite requires every expert to succeed on at
least 90% of the seeds; the exit status is 1 when one does not.
"""

from __future__ import annotations

import argparse
import json
import sys

from icil_paper.results import results_root


def main(argv: list[str] | None = None) -> int:
    from icil_paper.sim import measure_experts

    parser = argparse.ArgumentParser(prog="python -m icil_paper.sim.kitchen.measure_experts",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=50, help="random scene seeds per task")
    parser.add_argument("--seed", type=int, default=0, help="seed of the seed draw")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--suites", nargs="*", default=["kitchen", "kinova"],
                        choices=["kitchen", "kinova"])
    parser.add_argument("--no-human", action="store_true", help="skip the human-source episodes")
    args = parser.parse_args(argv)
    status = 0
    rows = []
    for suite in args.suites:
        sub = ["--suite", suite, "--seeds", str(args.seeds), "--seed", str(args.seed),
               "--workers", str(args.workers)] + (["--no-human"] if args.no_human else [])
        status |= measure_experts.main(sub)
        record = json.loads((results_root() / "experts" / f"{suite}.json").read_text())
        rows += list(record["tasks"].items())
    print(f"\n{'task':26s} {'expert':>7s} {'replay':>7s} {'human':>7s} {'mean len':>9s}  "
          "failed seeds")
    for task, e in rows:
        human = e.get("human_success_rate")
        print(f"{task:26s} {e['expert_success_rate']:7.2f} {e['replay_success_rate']:7.2f} "
              f"{'' if human is None else f'{human:.2f}':>7s} "
              f"{e['mean_length'] or float('nan'):9.1f}  {e['failed_seeds']}")
    return status


if __name__ == "__main__":
    sys.exit(main())
