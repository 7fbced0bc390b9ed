"""The book's side of the library: what the chapters run and show.

- `studies.py`: the chapters' own experiments (tokenizers trained alone, the Lipschitz
  study, the showcase and expert stages of `reproduce`) and their seed means (`SeedRecords`).
- `report.py`: tables and ledgers by source, chapter 00's ledger and Sec. IV's questions,
  chapter 01's presets (`tables.display`: what every table shows).
- By chapter: `method.py` (02, 03), `components.py` (04, 05), `experiments.py` (06-13),
  `own_tokenizer.py` (14).

Nothing is imported here, so each module loads only what it needs.
"""
