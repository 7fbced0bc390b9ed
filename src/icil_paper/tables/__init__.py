"""The machinery under the paper's results: specs, execution, assembly, claims and display.

    from icil_paper.paper import run_tables, table_spec  # each result's table, one module each
    from icil_paper.results import ResultsStore
    from icil_paper.tables.assemble import assemble
    spec = table_spec(preset, "I")                 # rows x columns -> cells of (run, eval) units
    run_tables(preset, ["I", "II"], workers=2)     # trains and evaluates what the store lacks
    result = assemble(spec, ResultsStore(preset.name))   # estimates with 95% intervals

Each result of the paper (Tables I-VII, Figs. 1, 4 and 5, the prompt ablation, the analysis
table, the tokenizers since the paper, the official code) is one module of
`icil_paper.paper`: its table spec, its claims, the paper's numbers and how it is shown.
This package is what they are built from and run on, and imports none of them: the list of
results is `icil_paper.paper`'s (`TABLES`, `table_spec`, `claims`, `run_tables`), read by
the layers above (planning, the book, `reproduce`).

- `spec.py`: TableSpec, Row, Cell, Unit (FeatureSpec, like EvalSpec, is `icil_paper.runspec`'s).
- `definitions.py`: the building blocks of a table spec: a row's runs per training seed, their
  evaluations on shared episodes, the family cells, Table I's runs that other tables reuse.
- `cells.py`: the cells of any set of tables (one trained policy each, with every
  evaluation the tables ask of it), computed in this process, a process pool or on Ray.
- `assemble.py`: records -> numbers with intervals (`icil_paper.stats`), as tables.
- `claims.py`: the claims engine: a claim's comparison, its verdict, size and power, the
  ledger's entries and their sentences.
- `display.py`: what every result's chapter shows the same way (frames, figures, sentences,
  the reference run beside this build).
- `compare.py`: a tokenizer against LipVQ-VAE on Table I's protocol (`icil-paper compare`).

What the book reads across results (`load_table`, the ledger's views, the reference run's
bookkeeping, Sec. IV's questions, `icil-paper tables`) is `icil_paper.book.report`,
`book.questions` and `book.tables_cli`; the seed design, the cost and the plan for the
undecided claims are `icil_paper.planning`'s.
"""
