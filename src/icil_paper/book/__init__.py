"""The book's side of the library: what the chapters run and show.

- `studies.py`: the chapters' own experiments (tokenizers trained alone, the Lipschitz
  study, the showcase and expert stages of `reproduce`) and their seed means (`SeedRecords`).
- By chapter: `ledger.py` (00, with Sec. IV's questions), `environment.py` (01), `method.py`
  (02, 03), `components.py` (04, 05), `experiments.py` (06-13), `own_tokenizer.py` (14);
  `report.py`: tables and ledgers by source (`tables.display`: what every table shows).

Nothing is imported here, so each module loads only what it needs.
"""
