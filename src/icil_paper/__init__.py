"""icil_paper: the library behind the companion to "Action Tokenizer Matters in
In-Context Imitation Learning" (LipVQ-VAE).

Submodules are imported lazily so that `import icil_paper` stays cheap:

- `icil_paper.config`     presets (`smoke`, `small`, `full`) and the config dataclasses
- `icil_paper.seeding`    the one seeding function, `seed_everything`
- `icil_paper.results`    the results store under `results/<preset>/`
- `icil_paper.tokenizers` every action tokenizer of the paper, behind `make_tokenizer`
- `icil_paper.metrics`    smoothness scores (least energy and its scale-free variants)
- `icil_paper.sim`        the task suites (`TASKS`, `make_env`, `make_expert`)
- `icil_paper.data`       demonstration data sets in the robomimic HDF5 layout
- `icil_paper.policies`   ICRT and the baselines
- `icil_paper.train`, `icil_paper.eval`   training and evaluation: each its loop, its stored
  records (named by `icil_paper.records`) and its command
- `icil_paper.paper`      one module per result of the paper (Table V in `paper/table_v.py`):
  its table spec, its claims, the paper's numbers and what its chapter shows
- `icil_paper.tables`     what the results are built from: specs executed on a grid of cells,
  assembled with intervals, the claims engine, the views every chapter shares
- `icil_paper.planning`   above the tables: the seed design, a run's cost, the plan for the
  undecided claims (`icil-paper plan`) and the pilots
- `icil_paper.viz`        rerun recordings of episodes and the viewer that embeds them in a page
- `icil_paper.book`, `icil_paper.setup`, `icil_paper.interop`   what the chapters run and
  show; this machine's checks and provenance; exports for other code bases

The tools that run the project (benchmarks, the browser check of the built book, system
setup, the README's figures) are not part of the library: they live in `tools/`.
"""

__version__ = "0.1.0"
