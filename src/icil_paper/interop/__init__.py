"""Interop: a trained tokenizer as a portable folder (`tokenizer_export.py`) and a data set as
a LeRobotDataset (`lerobot_export.py`, in its own environment).

Nothing is imported here, so each runs with only its own dependencies.
"""
