"""Demonstration sources: `generated` (the expert on randomized scenes) and `human`.

- `generated`: the task's scripted expert, our stand-in for MimicGen.
- `human`: the same expert driven by a model of a teleoperating person (`HumanLikeOperator`:
  OU hand noise, hesitations, drifting speed, overshoots), on the suite's `human` scenes
  where it has them (`source_env_options`).

Only successful episodes become demos. Demo `index` of a data set with base seed `b` is
played from `b + SOURCE_SEED_OFFSET[source] + index + attempt * ATTEMPT_STRIDE`, `attempt`
counting its failed episodes, so generation in any order gives the same demos.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from icil_paper.data.hdf5 import Demo
from icil_paper.registry import check_name
from icil_paper.sim import make_expert, scene_distributions

SOURCES = ("generated", "human")
SOURCE_SEED_OFFSET = {"generated": 0, "human": 500_000}
"""Seed offset of each source, so the two sources show different scenes."""
ATTEMPT_STRIDE = 1_000_000
"""Seed step between the attempts of one demo (data sets hold fewer demos than this)."""
MAX_ATTEMPTS = 20
"""Failed episodes of one demo after which generation gives up with an error."""
EVAL_SEED_BASE = 100_000_000
"""First seed of evaluation episodes: above every seed that demo generation can use."""


SOURCE_SCENES = {"generated": "generated", "human": "human"}
"""The scene distribution each source's episodes are played on, where the suite offers it."""


def source_env_options(source: str, task: str) -> dict[str, Any]:
    """The `make_env` options a source's episodes of `task` are played with: `scenes` where
    the suite offers the source's scene distribution other than as its default, else none."""
    check_name("demo source", source, SOURCES)
    offered = scene_distributions(task)
    scenes = SOURCE_SCENES[source]
    if scenes in offered and scenes != offered[0]:
        return {"scenes": scenes}
    return {}


def demo_seed(base_seed: int, source: str, index: int, attempt: int = 0) -> int:
    """The env seed of attempt `attempt` of demo `index` (see the module docstring)."""
    check_name("demo source", source, SOURCES)
    if not 0 <= index < 500_000 or not 0 <= attempt < MAX_ATTEMPTS * 4:
        raise ValueError(f"demo index {index} / attempt {attempt} out of range")
    return int(base_seed) + SOURCE_SEED_OFFSET[source] + int(index) + int(attempt) * ATTEMPT_STRIDE


ACTION_SCALES = {"maniskill": (0.1, 0.1), "kitchen": (0.05, 0.5), "kinova": (0.05, 0.5),
                 "metaworld": (0.01, 0.5)}
"""(metres, radians) of end-effector motion per action unit in each suite's controller."""


@dataclass(frozen=True)
class OperatorStyle:
    """Parameters of the teleoperating person that the `human` source imitates."""

    noise_pos_m: float = 0.002
    """Stationary std of the OU hand noise on each position dim, in metres per step."""
    noise_rot_rad: float = 0.01
    """Stationary std of the OU hand noise on each rotation dim, in radians per step."""
    noise_theta: float = 0.25
    """OU mean reversion per step (smaller: slower, smoother drift)."""
    pause_prob: float = 0.03
    """Chance per step that the operator hesitates."""
    pause_steps: tuple[int, int] = (2, 6)
    """Range (inclusive) of a hesitation's length in steps."""
    speed_range: tuple[float, float] = (0.6, 1.15)
    """Range of the speed factor that scales the motion dims."""
    speed_theta: float = 0.05
    """Mean reversion of the speed factor's (log) random walk per step."""
    speed_std: float = 0.25
    """Stationary std of the log speed factor."""
    overshoot_prob: float = 0.02
    """Chance per step of starting an overshoot (a correction follows from the expert)."""
    overshoot_gain: tuple[float, float] = (1.5, 2.2)
    """Range of the factor on the motion during an overshoot."""
    overshoot_steps: tuple[int, int] = (2, 4)
    """Range (inclusive) of an overshoot's length in steps."""


class ExpertSource:
    """The `generated` source: the expert itself (the seed argument is accepted and unused)."""

    def __init__(self, expert: Any):
        self.expert = expert

    def reset(self, env: Any, obs: dict[str, np.ndarray], seed: int | None = None) -> None:
        self.expert.reset(env, obs)

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        return np.asarray(self.expert.act(obs), dtype=np.float32)

    def close(self) -> None:
        close = getattr(self.expert, "close", None)
        if close is not None:
            close()


class HumanLikeOperator(ExpertSource):
    """Wrap any expert (`reset(env, obs)`, `act(obs)`) as a teleoperating person would drive it.

    While hesitating, the operator holds still and does not ask the expert, whose plan waits.
    """

    def __init__(self, expert: Any, style: OperatorStyle | None = None,
                 action_scale: tuple[float, float] = ACTION_SCALES["kitchen"]):
        self.expert = expert
        self.style = style or OperatorStyle()
        pos_scale, rot_scale = action_scale
        self.noise_std = np.array([self.style.noise_pos_m / pos_scale] * 3
                                  + [self.style.noise_rot_rad / rot_scale] * 3)
        self.rng = np.random.default_rng(0)

    def reset(self, env: Any, obs: dict[str, np.ndarray], seed: int | None = None) -> None:
        self.expert.reset(env, obs)
        if seed is None:
            seed = int(getattr(env, "seed", None) or 0)
        self.rng = np.random.default_rng([int(seed), 0x4855])  # "HU"
        self.noise = np.zeros(6)
        self.log_speed = 0.0
        self.pause_left = 0
        self.overshoot_left = 0
        self.overshoot = 1.0
        self.gripper = -1.0
        self.events = {"pauses": 0, "overshoots": 0}

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        s, rng = self.style, self.rng
        # OU hand noise and log-speed drift advance every step, paused or not
        self.noise += (-s.noise_theta * self.noise
                       + self.noise_std * np.sqrt(2 * s.noise_theta) * rng.standard_normal(6))
        self.log_speed += (-s.speed_theta * self.log_speed
                           + s.speed_std * np.sqrt(2 * s.speed_theta) * rng.standard_normal())
        start_pause = rng.random() < s.pause_prob
        start_overshoot = rng.random() < s.overshoot_prob
        if self.pause_left == 0 and start_pause:
            self.pause_left = int(rng.integers(s.pause_steps[0], s.pause_steps[1] + 1))
            self.events["pauses"] += 1
        if self.pause_left > 0:
            self.pause_left -= 1
            action = np.zeros(7, np.float32)
            action[:6] = 0.2 * self.noise  # a resting hand still trembles a little
            action[6] = self.gripper
            return np.clip(action, -1.0, 1.0)
        action = np.asarray(self.expert.act(obs), dtype=np.float64).copy()
        if self.overshoot_left == 0 and start_overshoot:
            self.overshoot_left = int(rng.integers(s.overshoot_steps[0], s.overshoot_steps[1] + 1))
            self.overshoot = float(rng.uniform(*s.overshoot_gain))
            self.events["overshoots"] += 1
        speed = float(np.clip(np.exp(self.log_speed), *s.speed_range))
        gain = speed * (self.overshoot if self.overshoot_left > 0 else 1.0)
        self.overshoot_left = max(self.overshoot_left - 1, 0)
        action[:6] = action[:6] * gain + self.noise
        self.gripper = float(action[6])
        return np.clip(action, -1.0, 1.0).astype(np.float32)


def make_source(source: str, task: str, expert: Any = None,
                style: OperatorStyle | None = None):
    """The action source of a data set: `generated` or `human` around the task's expert."""
    check_name("demo source", source, SOURCES)
    if expert is None:
        expert = make_expert(task)
    if source == "generated":
        return ExpertSource(expert)
    scale = ACTION_SCALES.get(task.split("/", 1)[0], ACTION_SCALES["kitchen"])
    return HumanLikeOperator(expert, style, action_scale=scale)


def expert_rollout(env: Any, policy: Any, seed: int, source: str = "generated",
                   record_states: bool = True, max_steps: int | None = None) -> tuple[Demo, bool]:
    """One episode of `policy` (a source) from `env.reset(seed=seed)`: (Demo, succeeded)."""
    obs, info = env.reset(seed=seed)
    policy.reset(env, obs, seed=seed)
    get_state = getattr(env, "get_state", None) if record_states else None
    keys = list(obs)
    frames: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    actions, rewards, states = [], [], []
    success = bool(info.get("success", False))
    steps = int(max_steps or env.horizon)
    for _ in range(steps):
        if success:
            break
        for k in keys:
            frames[k].append(obs[k])
        if get_state is not None:
            states.append(np.asarray(get_state(), np.float64))
        action = np.asarray(policy.act(obs), np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        actions.append(action)
        rewards.append(float(reward))
        success = bool(info["success"])
        if terminated or truncated:
            break
    cameras = tuple(getattr(env, "cameras", ()) or ()) if "rgb" in frames else ()
    if not actions:  # succeeded at reset: nothing to learn from
        return Demo(np.zeros((0, env.action_dim), np.float32), {}, env.name, source,
                    env.instruction, int(seed), cameras=cameras), False
    demo = Demo(
        actions=np.stack(actions).astype(np.float32),
        obs={k: np.stack(v) for k, v in frames.items()},
        task=env.name,
        source=source,
        instruction=env.instruction,
        seed=int(seed),
        states=np.stack(states) if states else None,
        rewards=np.asarray(rewards, np.float32),
        final_obs={k: np.asarray(obs[k]) for k in keys},
        cameras=cameras,
    )
    return demo, success


def style_dict(style: OperatorStyle | None = None) -> dict[str, Any]:
    """The operator parameters as a JSON-ready dict (stored with human data sets)."""
    return asdict(style or OperatorStyle())
