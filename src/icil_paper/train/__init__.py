"""Training: the one loop every policy shares, its run folders, and `icil-paper train`.

    from icil_paper.runspec import run_spec
    from icil_paper.train import run_dir_for, train_policy
    spec = run_spec(preset, "icrt", "lipvq", tasks=["kitchen/open_drawer"])
    result = train_policy(spec, run_dir=run_dir_for(spec, preset.name), preset=preset.name)

- `loop.py`: `train_policy`, `TrainState`, `TrainResult`, `training_demos`.
- `optim.py`: AdamW with decoupled decay, warm-up + cosine, EMA, CPU thread control.
- `rundir.py`: run folders, safe checkpoint / policy files, metrics lines.
- `cli.py`: `icil-paper train`.
"""

from icil_paper.train.cli import main
from icil_paper.train.loop import TrainResult, TrainState, train_policy, training_demos
from icil_paper.train.rundir import (
    CONFIG_FILE,
    METRICS_FILE,
    POLICY_FILE,
    PolicyFileError,
    RunFolderError,
    load_policy,
    policy_digest,
    read_metrics,
    run_dir_for,
    runs_root,
)

__all__ = ["CONFIG_FILE", "METRICS_FILE", "POLICY_FILE", "PolicyFileError", "RunFolderError",
           "TrainResult", "TrainState", "load_policy", "main", "policy_digest", "read_metrics",
           "run_dir_for", "runs_root", "train_policy", "training_demos"]
