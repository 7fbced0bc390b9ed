"""Training: the one loop every policy shares (`loop.py`), its run folders, its stored
records and `icil-paper train`."""

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
from icil_paper.train.stored import StaleRecordWarning, load_trained, train_run

__all__ = ["CONFIG_FILE", "METRICS_FILE", "POLICY_FILE", "PolicyFileError", "RunFolderError",
           "StaleRecordWarning", "TrainResult", "TrainState", "load_policy", "load_trained",
           "policy_digest", "read_metrics", "run_dir_for", "runs_root", "train_policy",
           "train_run", "training_demos"]
