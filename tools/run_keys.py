"""Every key a preset's run computes, so that a change to the code can be checked against
a run in progress: a refactoring that keeps the keys leaves every stored record current.

    python -m tools.run_keys > before.txt          # all presets
    python -m tools.run_keys --preset reference    # one preset
    diff before.txt <(python -m tools.run_keys)    # empty: no run key moved

For each preset it lists the data sets, the design record a staged run registers, the keys
of every planned cell's training, evaluations and features (a staged preset at each stage
with every claimed row there) and those of the chapters' own studies.
"""

from __future__ import annotations

import argparse
import json

from icil_paper.book.studies import study_keys
from icil_paper.config import PRESET_NAMES, get_preset
from icil_paper.data.generate import GENERATOR, demo_path, preset_tasks
from icil_paper.paper import TABLES, table_spec
from icil_paper.planning.design import claim_rows, with_row_seeds
from icil_paper.runspec import eval_key, feature_key
from icil_paper.tables.cells import plan
from icil_paper.tables.design import new_record


def preset_keys(name: str) -> list[str]:
    """Sorted lines "preset kind key" of everything the preset's run stores."""
    preset = get_preset(name)
    lines = {f"{name} data {GENERATOR} {'/'.join(demo_path(preset, t, s).parts[-4:])} seed "
             f"{preset.seed}" for t in preset_tasks(preset) for s in preset.data.sources}
    if preset.tables.seed_stages:
        lines.add(f"{name} design {json.dumps(new_record(preset), sort_keys=True)}")
    rows = {row for pairs in claim_rows(preset).values() for row in pairs}
    for n in preset.tables.seed_stages or (None,):
        staged = preset if n is None else with_row_seeds(preset, dict.fromkeys(rows, n))
        for p in plan([table_spec(staged, t) for t in TABLES]):
            lines.add(f"{name} train {p.run.key()}")
            lines.update(f"{name} eval {eval_key(p.run, e)}" for e in p.evals.values())
            lines.update(f"{name} features {feature_key(p.run, f)}"
                         for f in p.features.values())
    for kind, keys in study_keys(preset).items():
        lines.update(f"{name} {kind} {k}" for k in keys)
    return sorted(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", choices=PRESET_NAMES, action="append",
                        help="only these presets (default: all)")
    args = parser.parse_args()
    for name in args.preset or PRESET_NAMES:
        print("\n".join(preset_keys(name)))


if __name__ == "__main__":
    main()
