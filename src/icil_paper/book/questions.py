"""The paper's three questions (Sec. IV: Q1-Q3) and the claims of the ledger that answer each.

    for q in QUESTIONS: q.decides, q.beside        # claim ids
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Question:
    """One of Sec. IV's questions and the claims of the ledger that answer it."""

    key: str
    """"Q1", "Q2" or "Q3", as the paper numbers them."""
    text: str
    """The question in plain words."""
    decides: tuple[str, ...]
    """The claims whose verdicts answer it."""
    beside: tuple[str, ...] = ()
    """Claims quoted beside them (they do not change the answer)."""


QUESTIONS = (
    Question("Q1", "Does the action tokenizer matter, and is LipVQ-VAE the best one?",
             ("I-lipvq-best", "II-lipvq-best", "I-tokenizer-gap"), ("I-lipvq-vs-bc",)),
    Question("Q2", "Does smoothness explain it?",
             ("III-lipvq-smoothest", "III-smoother-succeeds", "IV-vq")),
    Question("Q3", "Does it transfer from simulation to the real robot, across data sets and "
             "to unseen tasks?",
             ("V-lipvq-vs-bc", "V-lipvq-vs-bin"), ("VI-lipvq-best", "VII-lipvq-vs-bc")),
)
"""Sec. IV's Q1-Q3 (Q3 is sim-to-real in the paper; Tables VI and VII are quoted beside)."""
