"""The machinery under the paper's results: specs, execution, assembly, claims and display.

    from icil_paper.paper import table_spec            # each result's table, one module each
    from icil_paper.results import ResultsStore
    from icil_paper.tables.assemble import assemble
    from icil_paper.tables.execute import run_tables
    spec = table_spec(preset, "I")                 # rows x columns -> cells of (run, eval) units
    run_tables(preset, ["I", "II"], workers=2)     # trains and evaluates what the store lacks
    result = assemble(spec, ResultsStore(preset.name))   # estimates with 95% intervals

Each result of the paper (Tables I-VII, Figs. 1, 4 and 5, the prompt ablation, the analysis
table, the tokenizers since the paper, the official code) is one module of
`icil_paper.paper`: its table spec, its claims, the paper's numbers and how it is shown.
This package is what they are built from and run on; it reads the list of results only
through `icil_paper.paper` (in `execute.run_tables`, `book`, `questions`, `cli` and the
planning modules), and no result's module imports those.

- `spec.py`: TableSpec, Row, Cell, Unit (FeatureSpec, like EvalSpec, is `icil_paper.runspec`'s).
- `definitions.py`: the building blocks of a table spec: a row's runs per training seed, their
  evaluations on shared episodes, the family cells, Table I's runs that other tables reuse.
- `execute.py`: the cells of any set of tables grouped by trained run, fanned out with
  `icil_paper.tables.grid`, each writing its records through the results store.
- `grid.py`: cells of work on a local process pool or a Ray cluster, skipped when done.
- `assemble.py`: records -> numbers with intervals (`icil_paper.stats`), as tables.
- `claims.py`: the claims engine: a claim's comparison, its verdict, size and power, the
  ledger's entries and their sentences.
- `display.py`: what every result's chapter shows the same way (frames, figures, sentences,
  the reference run beside this build).
- `book.py`: what the book reads across results: `load_table`, the ledger's views (chapter 0),
  the reference run's bookkeeping; `questions.py`: Sec. IV's three questions answered.
- `design.py`, `cost.py`, `decide.py`: the seed design, a run's cost, the plan for the
  undecided claims (`icil-paper plan`); `compare.py`: a tokenizer against LipVQ-VAE on
  Table I's protocol (`icil-paper compare`).
- `cli.py`: `icil-paper tables`.
"""
