"""The book's side of the library: what the chapters run and show, and how the book is
checked. Chapters import from here and call; they define no experiments of their own.

- `studies.py`: the chapters' own experiments (tokenizers trained alone, the Lipschitz
  study, one ICRT run with its rollouts, the showcase and expert stages of `reproduce`).
- `summaries.py`: what chapters show of those records: means over training seeds,
  intervals, verdicts in words (`SeedRecords`).
- `recording.py`: rerun recordings of rollouts and of tokenizer latents.
- `viewer.py`: those recordings embedded in the book's pages.
- `browser_check.py`: the built book in Chromium (`make browser-check`).

Nothing is imported here, so each module loads only what it needs.
"""
