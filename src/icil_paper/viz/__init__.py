"""Pictures of episodes: rerun recordings and how a page shows them.

- `recording.py`: rerun recordings of demonstrations, rollouts and tokenizer latents, each
  with a static picture beside it (evaluation and the showcase data set record through it).
- `viewer.py`: those recordings embedded in the book's pages (the rerun web viewer, the
  picture, a download link).

Nothing is imported here, so each module loads only what it needs.
"""
