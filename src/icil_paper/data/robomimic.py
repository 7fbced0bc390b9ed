"""robomimic interoperability: the `env_args` our data sets carry, and any robomimic file as data.

Our data sets load in robomimic 0.3's own `SequenceDataset` with its default arguments
(layout in `icil_paper.data.hdf5`)::

    import robomimic.utils.obs_utils as ObsUtils
    from robomimic.utils.dataset import SequenceDataset
    ObsUtils.initialize_obs_utils_with_obs_specs({"obs": {
        "low_dim": ["proprio", "object"], "rgb": ["agentview_image"]}})
    data = SequenceDataset(path, obs_keys=("proprio", "object", "agentview_image"),
                           dataset_keys=("actions", "rewards", "dones"))

robomimic's env factory cannot build our environments, so train with
`experiment.rollout.enabled = False` and roll out through `icil_paper.sim`. The other way,
`load_dataset_file` reads any robomimic-layout file (robosuite, RoboCasa, MimicGen) as demos.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from icil_paper.data.hdf5 import (
    H5_ERRORS,
    DatasetError,
    Demo,
    _available,
    _damage,
    file_info,
    load_demos,
)
from icil_paper.data.obs_keys import ObsKeyMap, map_obs_keys
from icil_paper.sim import gym_id

ROBOMIMIC_GYM_TYPE = 2
"""robomimic's `EnvType.GYM_TYPE`: an env that `gym.make(env_name, **env_kwargs)` builds."""
ROBOMIMIC_NOTE = ("robomimic's env factory cannot build this env (its gym type imports the "
                  "legacy gym package); train with experiment.rollout.enabled=False and build "
                  "the env with icil_paper")


def robomimic_env_args(task: str, obs: str, env_options: Mapping[str, Any] | None = None,
                       control_freq: int | None = None) -> dict[str, Any]:
    """`data.attrs["env_args"]` of a data set of `task`, in robomimic's form."""
    return {
        "env_name": gym_id(task),
        "type": ROBOMIMIC_GYM_TYPE,
        "env_kwargs": {"obs": obs, **dict(env_options or {})},
        "icil_paper": {
            "task": task,
            "control_freq": control_freq,
            "make_env": "icil_paper.sim.make_env(task, **env_kwargs)",
            "gymnasium": "import icil_paper.sim; gymnasium.make(env_name, **env_kwargs)",
            "robomimic": ROBOMIMIC_NOTE,
        },
    }


def dataset_obs_keys(path: str | Path,
                     obs_keys: Sequence[str] | Mapping[str, Sequence[str]] | None = None
                     ) -> ObsKeyMap:
    """The key mapping `load_dataset_file(path, obs_keys)` uses (from the file's first demo)."""
    import h5py

    path = Path(path)
    info = file_info(path)
    if not info["demos"]:
        raise DatasetError(f"{path}: no demos under 'data' (expected groups named demo_N)")
    name = info["demos"][0]
    try:
        with h5py.File(path, "r") as f:
            group = f["data"][name]
            if "obs" not in group:
                raise DatasetError(f"{path}: demo {name!r}: missing key 'obs'")
            available = _available(group["obs"])
    except H5_ERRORS as exc:
        raise DatasetError(f"{path}: the file is damaged ({_damage(exc)})") from None
    try:
        return map_obs_keys(available, obs_keys)
    except ValueError as exc:
        raise DatasetError(f"{path}: demo {name!r}: {exc}") from None


def load_dataset_file(path: str | Path,
                      obs_keys: Sequence[str] | Mapping[str, Sequence[str]] | None = None,
                      action_dim: int | None = None, limit: int | None = None,
                      images: bool = True) -> list[Demo]:
    """The demos of any robomimic-layout HDF5 file, as training data (`train --dataset`).

    Observation keys map as `data.obs_keys` documents, or as `obs_keys` lists them. A demo's
    task is its `task` attribute, else the file's, else the file's stem. Raises DatasetError
    as `load_demos` does.
    """
    path = Path(path)
    demos = load_demos(path, action_dim=action_dim, limit=limit, images=images,
                       obs_keys=obs_keys)
    for demo in demos:
        if not demo.task:
            demo.task = path.stem
    return demos
