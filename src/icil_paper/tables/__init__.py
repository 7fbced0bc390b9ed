"""The machinery under the paper's results: specs, execution, assembly, claims and display.

    from icil_paper.paper import run_tables, table_spec  # each result's table, one module each
    from icil_paper.results import ResultsStore
    from icil_paper.tables.assemble import assemble
    spec = table_spec(preset, "I")                 # rows x columns -> cells of (run, eval) units
    run_tables(preset, ["I", "II"], workers=2)     # trains and evaluates what the store lacks
    result = assemble(spec, ResultsStore(preset.name))   # estimates with 95% intervals

`spec` (TableSpec, Row, Entry, Unit), `definitions` (a table spec's building blocks), `cells`
(computing cells: serial, process pool or Ray), `assemble` (records -> numbers), `claims`,
`design`, `display` and `compare` (`icil-paper compare`). It imports no `icil_paper.paper`.
"""
