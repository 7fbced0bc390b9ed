"""Interop: this library's data and models read by other code bases.

- `tokenizer_export.py`: a trained policy's tokenizer as a portable folder
  (`icil-paper export-tokenizer`; the format is `icil_paper.tokenizers.portable`'s).
- `lerobot_export.py`: a data set as a LeRobotDataset (runs in its own Python 3.12
  environment, `make lerobot-export`).

Nothing is imported here, so each runs with only its own dependencies.
"""
