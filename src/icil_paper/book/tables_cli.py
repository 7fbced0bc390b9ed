"""`icil-paper tables`: print the paper's tables from the results store (nothing is computed).

    icil-paper tables --preset reference                  # every table, markdown
    icil-paper tables --table I IV --format csv
    icil-paper tables --claims                            # the claims ledger: each claim's
                                                          # family, decision, size and power
    icil-paper tables --format json > tables.json
    icil-paper tables --preset reference --retire-stale   # older code's records out of the store

Cells whose records are missing print as `not run`; `icil-paper reproduce --stages tables`
computes them.
"""

from __future__ import annotations

import argparse
import json
import sys

from icil_paper.book.report import OLDER_RECORDS, retire_stale_records
from icil_paper.commands import Parser, add_preset_arguments, preset_from_args
from icil_paper.paper import TABLES, claims_ledger, table_spec
from icil_paper.planning.staged import as_run
from icil_paper.registry import check_name
from icil_paper.results import ResultsStore
from icil_paper.tables.assemble import assemble
from icil_paper.tables.claims import sentence
from icil_paper.tables.design import ONE_FAMILY


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="icil-paper tables", description=__doc__.split("\n\n")[0])
    add_preset_arguments(p)
    p.add_argument("--table", nargs="+", default=None, metavar="ID",
                   help=f"tables to print (default: all): {', '.join(TABLES)}")
    p.add_argument("--format", choices=("md", "csv", "json"), default="md",
                   help="markdown (default), CSV (one line per cell) or JSON")
    p.add_argument("--claims", action="store_true", help="print the claims ledger instead")
    p.add_argument("--no-paper", action="store_true", help="leave out the paper's numbers")
    p.add_argument("--retire-stale", action="store_true",
                   help="move the records no current table computes (an older version of the "
                        "code made them) to results/<preset>/older-code/records/ and stop")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    preset = preset_from_args(args)
    store = ResultsStore(preset.name)
    preset = as_run(preset, store)  # seeds in stages: the seeds the run has reached
    if args.retire_stale:
        moved = retire_stale_records(preset.name)
        print(f"moved {sum(moved.values())} records to {store.dir / OLDER_RECORDS}"
              + "".join(f"\n  {n} made by {commit}" for commit, n in moved.items()))
        return 0
    if args.claims:
        ledger = claims_ledger(preset, store)
        if args.format == "json":
            print(json.dumps([e.to_dict() for e in ledger], indent=2))
        else:
            if any(e.family == ONE_FAMILY for e in ledger):
                print("A record of the older design (its records were gathered under it; "
                      "the current design decides nothing on them):")
            for entry in ledger:
                size = f", {entry.size}" if entry.size else ""
                power = "" if entry.power is None else f", power {entry.power:.0%}"
                print(f"[{entry.adjusted_verdict}{size}] {entry.id} (Table {entry.table}, "
                      f"{entry.family or 'no family'}{power}): {sentence(entry)}")
        return 0
    ids = [check_name("table", t, TABLES) for t in (args.table or TABLES)]
    results = [assemble(table_spec(preset, t), store) for t in ids]
    if args.format == "json":
        print(json.dumps([r.to_json() for r in results], indent=2))
        return 0
    for result in results:
        spec = result.spec
        if args.format == "csv":
            frame = result.frame(paper=not args.no_paper)
            frame.insert(0, "table", spec.id)
            print(frame.to_csv(index=False), end="")
            continue
        status = "complete" if result.complete else f"{result.missing} unit(s) not run"
        print(f"## Table {spec.id}: {spec.title} [{preset.name}; {status}]\n")
        print(result.markdown(paper=not args.no_paper))
        print(f"\n{spec.note}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
