"""The stages of `icil-paper reproduce` (`icil_paper.reproduce.STAGES`): what each is, the
table stages' order, and how the table stages run their cells (`GRID`). It imports nothing of
the package, so the modules that read it sit below the runner.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Stage:
    """One step of the reproduction."""

    name: str
    """Short name, usable with --stages."""
    description: str
    """What it computes."""
    run: Callable[[Any, Any, bool], None]
    """The function called as run(preset, store, force)."""


TABLE_STAGES: tuple[tuple[str, str, str], ...] = (
    ("icrt", "train a small ICRT + LipVQ-VAE and roll it out from prompts", "02"),
    ("I", "Table I: every policy on the Meta-World tasks of RoboCasa's families", "06"),
    ("IV", "Table IV: the Lipschitz ablation (shares Table I's cells)", "09"),
    ("fig5", "Fig. 5: LipVQ-VAE's codebook size", "09"),
    ("III", "Table III: smoothness of the trained policies' latent features", "08"),
    ("V", "Table V: sim-to-real stand-in, Panda -> perturbed Kinova3", "10"),
    ("VI", "Table VI: cross-dataset, prompted with human-like demonstrations", "10"),
    ("prompt", "prompt ablation: right, wrong and truncated prompts", "10"),
    ("VII", "Table VII: zero-shot on ML45's held-out tasks", "10"),
    ("II", "Table II: ACT with each tokenizer on ManiSkill", "07"),
    ("analysis", "is it smoothness? Lipschitz, scale and collapse variants", "11"),
    ("beyond", "tokenizers since the paper: FSQ, residual VQ, B-splines, with and "
               "without Eq. 4", "12"),
    ("official", "the paper against its official code: LipVQ-VAE, Bin and prompts as the "
                 "code has them", "13"),
)
"""(table id, what it computes, chapter) of each table stage `table-<id>`, in run order."""


GRID = {"executor": "local", "workers": None, "ray_address": None, "gpus_per_cell": 0.0}
"""How the table stages run their cells (set from the command line: `reproduce.main`)."""
