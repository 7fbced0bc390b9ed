"""The sim-to-real stand-in: Kinova Gen3 door and drawer tasks with a simulated reality gap.

The same two fixtures driven by robosuite's `Kinova3` arm under a "reality gap" drawn anew
every episode: fixture damping, friction and part mass scaled at random, and Gaussian noise
on every observation entry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RealityGap:
    """Per-episode perturbation of the Kinova tasks."""

    damping_scale: tuple[float, float] = (0.5, 2.0)
    """Range of the factor on the fixture joint's damping (sampled log-uniformly)."""
    friction_scale: tuple[float, float] = (0.5, 2.0)
    """Range of the factor on the fixture joint's friction loss (log-uniform)."""
    mass_scale: tuple[float, float] = (0.7, 1.5)
    """Range of the factor on the mass (and inertia) of the fixture's moving part (uniform)."""
    obs_noise_std: float = 0.002
    """Std of Gaussian noise added to every proprio and object entry (m or rad)."""


class DynamicsPerturbation:
    """Scales a fixture's joint damping, friction and part mass from their nominal values."""

    def __init__(self, gap: RealityGap):
        self.gap = gap
        self._nominal = None
        self.last_scales: dict[str, float] = {}

    def bind(self, sim, dof_ids: list[int], body_ids: list[int]) -> None:
        m = sim.model
        self.dof_ids, self.body_ids = list(dof_ids), list(body_ids)
        self._nominal = (m.dof_damping[self.dof_ids].copy(),
                         m.dof_frictionloss[self.dof_ids].copy(),
                         m.body_mass[self.body_ids].copy(), m.body_inertia[self.body_ids].copy())

    def apply(self, sim, rng: np.random.Generator) -> dict[str, float]:
        damping, friction, mass, inertia = self._nominal
        g = self.gap
        scales = {"damping": float(np.exp(rng.uniform(*np.log(g.damping_scale)))),
                  "friction": float(np.exp(rng.uniform(*np.log(g.friction_scale)))),
                  "mass": float(rng.uniform(*g.mass_scale))}
        m = sim.model
        m.dof_damping[self.dof_ids] = damping * scales["damping"]
        m.dof_frictionloss[self.dof_ids] = friction * scales["friction"]
        m.body_mass[self.body_ids] = mass * scales["mass"]
        m.body_inertia[self.body_ids] = inertia * scales["mass"]
        self.last_scales = scales
        return scales
