"""The stages of `icil-paper reproduce`, in order, and how its table stages run their cells.

    for stage in STAGES: print(stage.name, stage.description)   # environment .. claims

Each stage names the library function it calls (`stage.target`, "module:function", imported
when the stage runs, as a registry imports its entries), so this table sits below every
module a stage calls: the runner (`icil_paper.reproduce`), the planning modules that count
a run's cost by stage (`planning.cost`) and the chapters' studies that a stage runs
(`book.studies`, `book.own_tokenizer`, which reads `GRID`) all import it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Stage:
    """One step of the reproduction."""

    name: str
    """Short name, usable with --stages."""
    description: str
    """What it computes."""
    target: str
    """"module:function" called as function(preset, store, force)."""


STAGES: tuple[Stage, ...] = (
    Stage("environment", "record the packages, hardware and simulator checks",
          "icil_paper.reproduce:record_environment"),
    Stage("demos", "generate every data set of the preset: all tasks, both sources (chapter 04)",
          "icil_paper.book.studies:demo_stage"),
    Stage("experts", "measure every expert on data.expert_seeds random scenes (chapter 04)",
          "icil_paper.book.studies:expert_study"),
    Stage("showcase", "render and record one demonstration of every task (chapter 04)",
          "icil_paper.book.studies:showcase_study"),
    Stage("table-icrt", "train a small ICRT + LipVQ-VAE and roll it out from prompts "
          "(chapter 02)", "icil_paper.reproduce:table_icrt"),
    Stage("lipschitz", "Lipschitz bounds vs empirical constants of trained encoders (chapter 03)",
          "icil_paper.book.studies:lipschitz_study"),
    Stage("tokenizers", "train every action tokenizer alone and score it (chapter 05)",
          "icil_paper.book.studies:tokenizer_study"),
    *(Stage(f"table-{t}", f"{what} (chapter {chapter})", f"icil_paper.reproduce:table_{t}")
      for t, what, chapter in (
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
          ("official", "the paper against its official code: LipVQ-VAE, Bin and prompts "
                       "as the code has them", "13"))),
    Stage("own-tokenizer", "a tokenizer of one file, loaded as a plugin, against LipVQ-VAE "
          "on Table I's protocol (chapter 14)",
          "icil_paper.book.own_tokenizer:own_tokenizer_study"),
    Stage("claims", "the claims ledger: every claim with its verdict (chapter 00)",
          "icil_paper.reproduce:claims_stage"),
)


GRID = {"executor": "local", "workers": None, "ray_address": None, "gpus_per_cell": 0.0}
"""How the table stages run their cells (set from the command line: `reproduce.main`)."""
