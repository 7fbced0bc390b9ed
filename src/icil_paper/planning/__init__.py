"""Planning a run: how many seeds, what it costs, what would decide the rest, and the pilots.

- `design.py`: the seed design of the reference preset, from the claims' power and the
  split of seed and episode variance, and its projected cost
  (`python -m icil_paper.planning.design`).
- `staged.py`: seeds in stages as run: the seeds every row has reached, from the records
  (what `reproduce`, the book and the cost read).
- `cost.py`: what a preset's run cost, from its records (`results/<preset>/cost.json`).
- `decide.py`: `icil-paper plan`, the seeds, cells and CPU-hours that would decide every
  undecided claim.
- `pilot.py`: the records of the pilots behind the reference preset's task scale and
  training regime, as the chapters read them (the pilots run from `tools/pilot.py`,
  `make pilot`).

Planning sits above the paper's tables: it reads `icil_paper.tables` (specs, plans, the
claims ledger), and nothing in `icil_paper.tables` imports it. Nothing is imported here, so
each module loads only what it needs.
"""
