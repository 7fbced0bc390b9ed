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

- `spec.py`, `definitions.py`: a table spec and its building blocks (rows, runs, cells).
- `execute.py`, `grid.py`: run the cells (a local process pool or a Ray cluster), skipping
  what the results store holds.
- `assemble.py`: records -> numbers with intervals (`icil_paper.stats`), as tables.
- `claims.py`: a claim's comparison, verdict, size and power.
- `display.py`: what every result's chapter shows the same way.
- `compare.py`: a tokenizer against LipVQ-VAE on Table I's protocol (`icil-paper compare`).
"""
