"""Every measured figure of the README and CONTRIBUTING.md is the value of the record it
names."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from tools.readme_figures import DOCUMENTS, FIGURES, MARKED, figure, printed_at

README = Path(__file__).resolve().parents[1] / "README.md"


def significant_digits(printed: str) -> int:
    """"15.6" -> 3, "-4.4" -> 2, "0.074" -> 2, "241" -> 3, "290" -> 2 (an integer's trailing zeros are
    not significant)."""
    digits = printed.replace(",", "").lstrip("-")
    if "." in digits:
        return len(digits.replace(".", "").lstrip("0"))
    return len(digits.lstrip("0").rstrip("0")) or 1


def rounded(value: float, digits: int) -> float:
    if value == 0:
        return 0.0
    return round(value, digits - 1 - int(math.floor(math.log10(abs(value)))))


def marked_figures() -> list[tuple[str, str]]:
    return [(printed, name) for path in DOCUMENTS
            for printed, _, name in MARKED.findall(path.read_text())]


def test_the_readme_marks_its_measured_figures():
    names = [name for _, name in marked_figures()]
    assert len(names) >= 15
    unknown = sorted(set(names) - set(FIGURES))
    assert not unknown, f"README figures with no computation in tools/readme_figures.py: {unknown}"
    markers = [m for path in DOCUMENTS
               for m in re.findall(r"<!-- figure: ([\w.-]+) -->", path.read_text())]
    assert len(markers) == len(names), "a marker that does not follow a number"
    assert README in DOCUMENTS and all(p.exists() for p in DOCUMENTS)


@pytest.mark.parametrize("printed,name", marked_figures())
def test_each_readme_figure_matches_its_record(printed, name):
    value = figure(name)
    expected = float(printed.replace(",", ""))
    assert rounded(value, significant_digits(printed)) == pytest.approx(expected), (
        f"README says {printed} for {name}; its record ({FIGURES[name][0]}) gives {value:.4g}")


def test_rounding_rules():
    assert significant_digits("15.6") == 3 and significant_digits("0.074") == 2
    assert significant_digits("290") == 2 and significant_digits("1217") == 4
    assert rounded(1217.497, 4) == 1217 and rounded(287.3, 2) == 290


def test_update_readme_prints_each_figure_as_it_was_printed():
    assert printed_at(6.2349, "6.2") == "6.2" and printed_at(241.6, "241") == "242"
    assert printed_at(0.0741, "0.074") == "0.074" and printed_at(12.0, "6.50") == "12.00"


def test_the_readmes_first_screen_says_what_the_book_concludes_from_the_ledger():
    """Before the two commands: what the book concludes about the paper, its numbers
    computed from the committed ledger (`claims.*` figures), in at most two sentences."""
    first = README.read_text().split("## Two commands")[0]
    conclusion = first[first.index("**What the book concludes.**"):]
    names = [name for _, _, name in MARKED.findall(conclusion)]
    assert {"claims.total", "claims.holds", "claims.undecided"} <= set(names)
    prose = re.sub(r"<!--.*?-->", "", conclusion).replace("Sec. IV", "Sec IV")
    assert prose.count(". ") + prose.rstrip().endswith(".") <= 3  # heading + two sentences


def test_the_conclusion_is_written_from_the_finished_ledger():
    """The README's conclusion sentence is written once the run has finished, from its ledger."""
    assert "CONCLUSION-SENTENCE" not in README.read_text()


CONCLUSION_VERDICTS = {
    "I-lipvq-vs-bc": "holds", "I-lipvq-vs-lfq": "holds", "beyond-eq4-rvq": "holds",
    "II-lipvq-vs-act": "does not hold", "I-lipvq-best": "inconclusive",
    "III-lipvq-smoothest": "inconclusive", "V-lipvq-vs-bc": "inconclusive",
}
"""What the README's conclusion says of each claim it names, in the ledger's words."""


def test_the_conclusions_words_are_the_ledgers_decisions():
    """The conclusion says "beats", "does not help", "stays undecided": each is the decision
    (after the design's correction) of the committed ledger."""
    import json
    ledger = json.loads((README.parent / "results/reference/claims.json").read_text())
    decided = {c["id"]: c["adjusted_verdict"] for c in ledger["claims"]}
    assert {k: decided[k] for k in CONCLUSION_VERDICTS} == CONCLUSION_VERDICTS
    quoted = {name.split(".")[1] for _, name in marked_figures() if name.startswith("claim.")}
    assert quoted <= set(CONCLUSION_VERDICTS)
