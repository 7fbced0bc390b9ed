"""A policy that needs no training, for the evaluation and rollout tests: it reads the goal
off its prompt (where the demonstration ended) and steers there with the synthetic reach
task's expert. It has no batched methods of its own, so the rollout pool's fallback to one
episode at a time is what drives it."""

from __future__ import annotations

import numpy as np

from icil_paper.policies.base import Policy, validate_prompt
from icil_paper.sim.synthetic import STEP_SIZE, expert_action


class OraclePolicy(Policy):
    """Reads the goal off its prompt and steers there."""

    name = "oracle"
    uses_prompt = True

    def reset(self, prompt=None, instruction=None):
        demo = validate_prompt(prompt, self.obs_spec, self.action_dim)[0]
        self.goal = demo.obs["proprio"][-1, :3] + STEP_SIZE * demo.actions[-1, :3]

    def select_action(self, obs):
        return expert_action(obs["proprio"].astype(np.float64), self.goal, 7).astype(np.float32)
