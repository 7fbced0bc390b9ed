"""Which observation keys of an HDF5 file become the project's `proprio`, `object`, `rgb`, `depth`.

    keys = map_obs_keys(available)          # available: key -> (shape, dtype kind)
    keys = map_obs_keys(available, ["robot0_eef_pos", "agentview_image"])   # chosen keys

Files of this project store the four entries directly; files of robosuite / robomimic tools
(RoboCasa, MimicGen) are mapped as `ROBOMIMIC_KEY_MAP` says. Keys none of these take are
dropped and named in a warning. `obs_keys` (`--obs-keys`) chooses instead: a list of key
names sent to an entry by those rules, or a mapping {"proprio": [...], "rgb": [...], ...}.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

ROBOSUITE_PROPRIO_KEYS = ("robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos")
ROBOT_KEY_PREFIXES = ("robot", "eef", "ee_", "tcp", "gripper", "joint", "qpos", "qvel")
"""Name prefixes of low-dim keys that describe the robot (they go to `proprio`)."""
ROBOMIMIC_KEY_MAP = {
    "proprio": "obs/proprio, else robot0_eef_pos | robot0_eef_quat | robot0_gripper_qpos, "
               "else every low-dim robot key (sorted)",
    "object": "obs/object, else every other low-dim key (sorted)",
    "rgb": "<camera>_image for every camera, sorted by name",
    "depth": "<camera>_depth for every camera, sorted by name",
}
"""How observation keys of robosuite / robomimic files map onto the project's keys."""
ENTRIES = ("proprio", "object", "rgb", "depth")


@dataclass(frozen=True)
class ObsKeyMap:
    """The file keys that make each of the project's observation entries, and those dropped."""

    proprio: tuple[str, ...]
    """Low-dim keys concatenated into `proprio`, in order."""
    object: tuple[str, ...]
    """Low-dim keys concatenated into `object`, in order."""
    rgb: tuple[str, ...] = ()
    """Image keys stacked into `rgb` along the camera axis, in order."""
    depth: tuple[str, ...] = ()
    """Depth keys stacked into `depth` along the camera axis, in order."""
    dropped: tuple[str, ...] = ()
    """Observation keys of the file that none of the entries use."""

    def without_images(self) -> ObsKeyMap:
        return ObsKeyMap(self.proprio, self.object, (), (), self.dropped)

    def describe(self) -> str:
        parts = [f"{entry} = {' | '.join(getattr(self, entry)) or '(none)'}"
                 for entry in ENTRIES if entry in ("proprio", "object") or getattr(self, entry)]
        return "; ".join(parts)


def is_image_key(key: str) -> bool:
    return key == "rgb" or key.endswith("_image")


def is_depth_key(key: str) -> bool:
    return key == "depth" or key.endswith("_depth")


def is_robot_key(key: str) -> bool:
    return key == "proprio" or key.startswith(ROBOT_KEY_PREFIXES)


def is_low_dim(shape: Sequence[int], kind: str) -> bool:
    """A (T,) or (T, d) array of numbers (dtype kind f, i, u or b)."""
    return len(shape) in (1, 2) and kind in "fiub"


def camera_of(key: str) -> str:
    """`agentview_image` -> `agentview` (the camera a per-camera image or depth key names)."""
    for suffix in ("_image", "_depth"):
        if key.endswith(suffix):
            return key[: -len(suffix)]
    return key


def map_obs_keys(available: Mapping[str, tuple[Sequence[int], str]],
                 obs_keys: Sequence[str] | Mapping[str, Sequence[str]] | None = None,
                 own: bool = False, camera_order: Sequence[str] | None = None) -> ObsKeyMap:
    """Map a file's observation keys (key -> (shape, dtype kind)) onto the project's entries.

    `own`: a file of this project (its own `proprio` and `object`); `camera_order`: the
    file's camera order, else by name. ValueError names a missing or unusable key.
    """
    names = sorted(available)
    listing = f"observation keys of the file: {', '.join(names) or '(none)'}"

    def usable(key: str, entry: str) -> str:
        if key not in available:
            raise ValueError(f"missing key 'obs/{key}' (for {entry}); {listing}")
        shape, kind = available[key]
        if entry in ("proprio", "object") and not is_low_dim(shape, kind):
            raise ValueError(f"obs/{key} cannot go into {entry}: it is not a (T,) or (T, d) "
                             f"numeric array (shape {tuple(shape)})")
        return key

    def ordered(keys: Sequence[str]) -> tuple[str, ...]:
        if camera_order is None:
            return tuple(sorted(keys))
        rank = {camera: i for i, camera in enumerate(camera_order)}
        return tuple(sorted(keys, key=lambda k: (rank.get(camera_of(k), len(rank)), k)))

    if isinstance(obs_keys, Mapping):
        unknown = set(obs_keys) - set(ENTRIES)
        if unknown:
            raise ValueError(f"obs_keys entries must be among {', '.join(ENTRIES)}, got "
                             f"{sorted(unknown)}")
        chosen = {entry: tuple(usable(k, entry) for k in obs_keys.get(entry, ()))
                  for entry in ENTRIES}
    elif obs_keys is not None:
        if isinstance(obs_keys, str):
            obs_keys = [obs_keys]
        chosen = {entry: () for entry in ENTRIES}
        for key in obs_keys:
            entry = ("rgb" if is_image_key(key) else "depth" if is_depth_key(key)
                     else "proprio" if is_robot_key(key) else "object")
            chosen[entry] += (usable(key, entry),)
    elif own:
        chosen = {"proprio": (usable("proprio", "proprio"),),
                  "object": (usable("object", "object"),),
                  "rgb": ordered(k for k in names if is_image_key(k)),
                  "depth": ordered(k for k in names if is_depth_key(k))}
    else:
        low_dim = [k for k in names if is_low_dim(*available[k])
                   and not is_image_key(k) and not is_depth_key(k)]
        if "proprio" in available:
            proprio = (usable("proprio", "proprio"),)
        elif any(k in available for k in ROBOSUITE_PROPRIO_KEYS):
            proprio = tuple(usable(k, "proprio") for k in ROBOSUITE_PROPRIO_KEYS
                            if k in available)
        else:
            proprio = tuple(k for k in low_dim if is_robot_key(k))
        if "object" in available:
            obj = (usable("object", "object"),)
        else:
            obj = tuple(k for k in low_dim if k not in proprio and not is_robot_key(k))
        chosen = {"proprio": proprio, "object": obj,
                  "rgb": ordered(k for k in names if is_image_key(k)),
                  "depth": ordered(k for k in names if is_depth_key(k))}
    used = {k for keys in chosen.values() for k in keys}
    return ObsKeyMap(chosen["proprio"], chosen["object"], chosen["rgb"], chosen["depth"],
                     tuple(k for k in names if k not in used))
