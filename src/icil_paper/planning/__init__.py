"""Planning a run: how many seeds, what it costs, what would decide the rest, and the pilots.

- `design.py`: the seed design and its projected cost (`python -m icil_paper.planning.design`).
- `staged.py`: seeds in stages as run, read from the records.
- `cost.py`: what a preset's run cost, from its records (`results/<preset>/cost.json`).
- `decide.py`: `icil-paper plan`, the seeds and CPU-hours that would decide every claim.
- `pilot.py`: the pilots' records as the chapters read them.

Nothing is imported here, so each module loads only what it needs.
"""
