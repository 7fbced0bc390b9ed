"""Pictures of episodes: rerun recordings with a static picture (`recording.py`) and their
viewer in the book's pages (`viewer.py`).

Nothing is imported here, so each module loads only what it needs.
"""
