"""Demonstration data sets in robomimic's HDF5 layout.

    from icil_paper.data import ensure_demos, load_demos
    path = ensure_demos("small", "maniskill/pick_cube", "generated")   # generates what is missing
    demos = load_demos(path, action_dim=7)                             # validated list[Demo]
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
