"""icil_paper: the library behind the companion to "Action Tokenizer Matters in
In-Context Imitation Learning" (LipVQ-VAE).

Submodules are imported lazily so that `import icil_paper` stays cheap:

- `icil_paper.config`     presets (`smoke`, `small`, `full`) and the config dataclasses
- `icil_paper.tokenizers` every action tokenizer of the paper, behind `make_tokenizer`
- `icil_paper.policies`   ICRT and the baselines
- `icil_paper.sim`        the task suites (`TASKS`, `make_env`, `make_expert`)
- `icil_paper.data`       demonstration data sets in the robomimic HDF5 layout
- `icil_paper.train`, `icil_paper.eval`   training and evaluation, each with its records
- `icil_paper.metrics`    smoothness scores; `icil_paper.stats` intervals and tests
- `icil_paper.results`    the results store under `results/<preset>/`
- `icil_paper.paper`      one module per result of the paper (Table V in `paper/table_v.py`)
- `icil_paper.tables`     what the results are built from: specs, execution, assembly, claims
- `icil_paper.planning`   the seed design, a run's cost and the plan for undecided claims
- `icil_paper.viz`, `icil_paper.interop`   rerun recordings and viewer; exports
- `icil_paper.book`, `icil_paper.setup`    what the chapters show; this machine's checks

The tools that run the project (benchmarks, the browser check of the built book, system
setup, the README's figures) live in `tools/`, not in the library.
"""

__version__ = "0.1.0"
