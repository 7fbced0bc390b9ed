"""Demonstration data sets in robomimic's HDF5 layout.

    from icil_paper.data import ensure_demos, load_demos
    path = ensure_demos("small", "maniskill/pick_cube", "generated")   # generates what is missing
    demos = load_demos(path, action_dim=7)                             # validated list[Demo]

- `hdf5`: the `Demo` dataclass, `write_demos`, `load_demos` (also reads robosuite / robomimic
  files such as RoboCasa's and MimicGen's), `verify_file`, `DatasetError` naming file, demo
  and problem.
- `obs_keys`: how a file's observation keys become `proprio`, `object`, `rgb`, `depth`.
- `robomimic`: `load_dataset_file` (any robomimic-layout file as training data, the contract
  of `icil-paper train --dataset`), the `env_args` of our data sets.
- `sources`: the `generated` (expert) and `human` (teleoperation-like) demonstration sources.
- `generate`: `ensure_demos` / `ensure_many` / `demo_path`, parallel, resumable generation.
- `splits`: train/valid masks, the zero-shot task split, the sim-to-real task pairs.
- `trajectories`: synthetic minimum-jerk action trajectories (tokenizer studies without a
  simulator).
- `experts`: every expert's success rate over random scenes, open-loop replays and the
  human source's keep rate (`python -m icil_paper.data.experts --suites ...`).
- `cli`: `icil-paper demos --task ... --source ... --n ...`.
"""

from icil_paper.data.generate import (
    DemoGenerationError,
    data_root,
    demo_path,
    ensure_demos,
    ensure_many,
    preset_tasks,
)
from icil_paper.data.hdf5 import (
    DatasetError,
    Demo,
    file_info,
    load_demos,
    read_masks,
    verify_file,
    write_demos,
)
from icil_paper.data.obs_keys import ROBOMIMIC_KEY_MAP, ObsKeyMap, map_obs_keys
from icil_paper.data.robomimic import dataset_obs_keys, load_dataset_file, robomimic_env_args
from icil_paper.data.sources import (
    EVAL_SEED_BASE,
    SOURCES,
    HumanLikeOperator,
    OperatorStyle,
    demo_seed,
    expert_rollout,
    make_source,
)
from icil_paper.data.splits import sim_to_real_pairs, train_valid_split, zero_shot_split

__all__ = [
    "Demo", "DatasetError", "DemoGenerationError", "EVAL_SEED_BASE", "HumanLikeOperator",
    "ObsKeyMap", "OperatorStyle", "ROBOMIMIC_KEY_MAP", "SOURCES", "data_root",
    "dataset_obs_keys", "demo_path", "demo_seed", "ensure_demos", "ensure_many", "file_info",
    "load_dataset_file", "load_demos", "make_source", "map_obs_keys", "preset_tasks",
    "read_masks", "robomimic_env_args", "expert_rollout", "sim_to_real_pairs", "train_valid_split",
    "verify_file", "write_demos", "zero_shot_split",
]
