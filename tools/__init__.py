"""The tools that run the project and are not part of the library `icil_paper`: the
benchmarks (`bench/`, `make bench`), the browser check of the built book (`browser_check.py`,
`make browser-check`), the system packages `make setup` installs (`system_deps.py`) and the
README's measured figures (`readme_figures.py`). Run them from the repository root as
`python -m tools.<name>`; nothing under `src/icil_paper` imports them."""
