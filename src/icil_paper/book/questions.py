"""The paper's three questions (Sec. IV: Q1-Q3) answered from a claims ledger, one plain
sentence each with the numbers that carry it, for the book's first page.

    answers(load_ledger("results/reference/claims.json"))   # [(question, answer), ...]

Q1 asks whether the action tokenizer matters and LipVQ-VAE is the best one (Tables I and
II), Q2 whether smoothness explains it (Tables III and IV), Q3 whether the method transfers
(Tables V-VII). Each question is decided by the verdicts after Holm's correction of the
claims that answer it (`Question.decides`); the claims beside them (`Question.beside`) are
quoted with their numbers but do not change the answer.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from icil_paper import verdict_words
from icil_paper.paper import CLAIM_LABELS
from icil_paper.tables.claims import LedgerEntry, as_entry


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


def quoted(entry: LedgerEntry) -> str:
    """"LipVQ-VAE best tokenizer, kitchen: -0.073 [-0.143, -0.003] against the paper's
    +0.041, inconclusive" (the verdict after Holm's correction)."""
    label = CLAIM_LABELS.get(entry.id, entry.id)
    if not entry.run or entry.ours is None:
        return f"{label}: not run yet"
    low, high = entry.ci
    paper = ("" if entry.paper is None else f" against the paper's {entry.paper:+.3f}")
    return (f"{label}: {entry.ours:+.3f} [{low:+.3f}, {high:+.3f}]{paper}, "
            f"{entry.adjusted_verdict}")


def answer(question: Question, ledger: Sequence[LedgerEntry | dict[str, Any]]) -> str:
    """The question answered in one sentence: the answer the decided claims give
    (`verdict_words.answer`), then each claim that carries it with its number, interval,
    the paper's number and verdict."""
    by_id = {e.id: e for e in map(as_entry, ledger)}
    deciding = [by_id[c] for c in question.decides if c in by_id]
    beside = [by_id[c] for c in question.beside if c in by_id]
    if not deciding:
        return "The ledger has none of the claims that answer it."
    lead = verdict_words.answer([e.adjusted_verdict for e in deciding])
    text = f"{lead}: " + "; ".join(quoted(e) for e in deciding)
    if beside:
        text += "; beside them, " + "; ".join(quoted(e) for e in beside)
    return text + "."


def answers(ledger: Sequence[LedgerEntry | dict[str, Any]]) -> list[tuple[Question, str]]:
    """Each of Sec. IV's questions with its answer from `ledger`."""
    return [(q, answer(q, ledger)) for q in QUESTIONS]


def answers_markdown(ledger: Sequence[LedgerEntry | dict[str, Any]]) -> str:
    """The answers as a Markdown list, one question a line, for the introduction."""
    return "\n".join(f"- **{q.key}. {q.text}** {a}" for q, a in answers(ledger))
