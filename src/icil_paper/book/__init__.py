"""The book's side of the library: what the chapters run and show. Chapters import from
here and call; they define no experiments of their own.

- `studies.py`: the chapters' own experiments (tokenizers trained alone, the Lipschitz
  study, one ICRT run with its rollouts, the showcase and expert stages of `reproduce`).
- `summaries.py`: what chapters show of those records: means over training seeds,
  intervals, verdicts in words (`SeedRecords`).
- What each chapter shows, by chapter group (findings, sentences, frames, figures; a
  chapter's cells call these and display the result): `ledger.py` (00, the claims
  ledgers and stale records), `environment.py` (01, the preset's fields and what works),
  `method.py` (02 and 03: ICRT's batch, mask, loss and rollout; Eq. 4's bounds),
  `components.py` (04 and 05: tasks and demonstrations; tokenizers trained alone),
  `experiments.py` (06-13, beside the tables of `icil_paper.tables`), `own_tokenizer.py`
  (14, the plugin example and its comparison); `display.py`: the display helpers they
  share.

Recordings and the viewer that embeds them are `icil_paper.viz`. The checks of the built book
and of the README's figures are the project's tools (`tools/browser_check.py`,
`tools/readme_figures.py`).

Nothing is imported here, so each module loads only what it needs.
"""
