"""The machinery under the paper's results: specs, execution, assembly, claims and display.

    from icil_paper.paper import run_tables, table_spec  # each result's table, one module each
    from icil_paper.results import ResultsStore
    from icil_paper.tables.assemble import assemble
    spec = table_spec(preset, "I")                 # rows x columns -> cells of (run, eval) units
    run_tables(preset, ["I", "II"], workers=2)     # trains and evaluates what the store lacks
    result = assemble(spec, ResultsStore(preset.name))   # estimates with 95% intervals

Each result of the paper is one module of `icil_paper.paper` (its table spec, claims, the
paper's numbers and display). This package is what they are built from and run on, and
imports none of them:

- `spec.py`: TableSpec, Row, Cell, Unit (FeatureSpec, like EvalSpec, is `icil_paper.runspec`'s).
- `definitions.py`: the building blocks of a table spec: a row's runs per training seed, their
  evaluations on shared episodes, the family cells, Table I's runs that other tables reuse.
- `cells.py`: the cells of any set of tables (one trained policy each, with every
  evaluation the tables ask of it), computed in this process, a process pool or on Ray.
- `assemble.py`: records -> numbers with intervals (`icil_paper.stats`), as tables.
- `claims.py`: a claim's comparison, verdict, size and power.
- `display.py`: what every result's chapter shows the same way.
- `compare.py`: a tokenizer against LipVQ-VAE on Table I's protocol (`icil-paper compare`).
"""
