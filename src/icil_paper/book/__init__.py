"""The book's side of the library: what the chapters run and show, and how the book is
checked. Chapters import from here and call; they define no experiments of their own.

- `studies.py`: the chapters' own experiments (tokenizers trained alone, the Lipschitz
  study, one ICRT run with its rollouts, the showcase and expert stages of `reproduce`).
- `summaries.py`: what chapters show of those records: means over training seeds,
  intervals, verdicts in words (`SeedRecords`).
- `browser_check.py`: the built book in Chromium (`make browser-check`).
- `figures.py`: the measured figures of the README and CONTRIBUTING.md, from their records
  (`python -m icil_paper.book.figures --update-readme`).

Recordings and the viewer that embeds them are `icil_paper.viz`.

Nothing is imported here, so each module loads only what it needs.
"""
