"""The paper's tables and figures, computed: specs, execution, statistics and claims.

    from icil_paper.tables import TABLES, table_spec, run_tables, assemble
    spec = table_spec(preset, "I")                 # rows x columns -> cells of (run, eval) units
    run_tables(preset, ["I", "II"], workers=2)     # trains and evaluates what the store lacks
    result = assemble(spec, ResultsStore(preset.name))   # estimates with 95% intervals

- `spec.py`: TableSpec, Row, Cell, Unit (FeatureSpec, like EvalSpec, is `icil_paper.runspec`'s).
- `definitions.py`: Tables I-VII, Fig. 5 and the prompt ablation, from a preset.
- `execute.py`: the cells of any set of tables grouped by trained run, fanned out with
  `icil_paper.tables.grid`, each writing its records through the results store.
- `grid.py`: cells of work on a local process pool or a Ray cluster, skipped when done.
- `assemble.py`: records -> numbers with intervals (`icil_paper.stats`), as tables.
- `claims.py`: the claims ledger: every claim of the paper with a computed verdict.
- `official.py`: the paper against its official code: each departure's effect and verdict.
- `cli.py`: `icil-paper tables`.
"""

from icil_paper.tables.definitions import TABLES, table_spec

__all__ = ["TABLES", "table_spec"]
