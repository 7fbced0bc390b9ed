"""One vocabulary: a verdict is a `stats.Verdict`, and the words a chapter prints for it come
from `icil_paper.verdict_words` alone."""

from __future__ import annotations

from pathlib import Path

from icil_paper import verdict_words
from icil_paper.stats import Verdict


# --------------------------------------------------------------------------- one vocabulary
def verdict_literals(source: str, skip_class: str | None = None) -> list[tuple[int, str]]:
    """(line, text) of each string literal in `source` (docstrings aside) that spells a
    verdict: equal to a `stats.Verdict` value, or containing "does not hold"."""
    import ast

    from icil_paper.stats import Verdict

    values = {v.value for v in Verdict}
    tree = ast.parse(source)
    skipped = {id(n.value) for n in ast.walk(tree)
               if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name == skip_class:
            skipped |= {id(n) for n in ast.walk(node)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in skipped
            and (n.value in values or "does not hold" in n.value)]


def test_verdict_literals_are_found_in_code_and_not_in_docstrings():
    source = ('"""holds"""\nx = "holds"\ny = f"it does not hold: {x}"\n'
              'def f():\n    """does not hold"""\n    return {"inconclusive": 1}\n'
              'class Verdict:\n    HOLDS = "holds"\n')
    assert verdict_literals(source, skip_class="Verdict") == [
        (2, "holds"), (3, "it does not hold: "), (6, "inconclusive")]
    assert (8, "holds") in verdict_literals(source)


def test_no_verdict_is_spelled_outside_the_vocabulary():
    """A verdict is a `stats.Verdict`; the words printed for it come from
    `icil_paper.verdict_words`, never from a literal in another module or a chapter."""
    root = Path(__file__).resolve().parents[1]
    files = sorted([*(root / "src" / "icil_paper").rglob("*.py"), *(root / "notebooks").glob("*.py")])
    found = {}
    for path in files:
        rel = path.relative_to(root).as_posix()
        if rel == "src/icil_paper/verdict_words.py":
            continue
        skip = "Verdict" if rel == "src/icil_paper/estimates.py" else None
        hits = verdict_literals(path.read_text(), skip_class=skip)
        if hits:
            found[rel] = hits
    assert not found, f"verdicts spelled outside icil_paper.verdict_words: {found}"



def test_every_table_of_words_covers_the_verdicts_it_can_be_given():
    decided_or_not = set(Verdict) - {Verdict.NOT_RUN}
    for name in ("SMOOTHER", "TRAINING_WINDOW"):
        assert set(getattr(verdict_words, name)) == decided_or_not, name
    for name in ("ANALYSIS_SMOOTH", "ANALYSIS_SUCCESS", "OUTCOME", "COLOURS"):
        assert set(getattr(verdict_words, name)) == set(Verdict), name
    assert set(verdict_words.LEDGER_ORDER) == set(Verdict)
    for v in decided_or_not:
        assert verdict_words.claim_words(v, "above")
    assert verdict_words.claim_words("holds", "below") == "holds: our interval lies below 0"
    assert [verdict_words.counted(Verdict.DOES_NOT_HOLD, k) for k in (1, 2)] == [
        "1 does not hold", "2 do not hold"]


def test_a_stored_ledger_entry_reads_by_attribute_and_writes_back_key_for_key():
    """claims.json keeps its format: every committed entry read as a `LedgerEntry` is
    written back as the same keys in the same order; a field a newer ledger adds is kept
    in place and read as an attribute."""
    import json

    from icil_paper.tables.claims import LedgerEntry, load_ledger

    path = Path(__file__).resolve().parents[1] / "results" / "reference" / "claims.json"
    stored = json.loads(path.read_text())["claims"]
    entries = load_ledger(path)
    for raw, entry in zip(stored, entries, strict=True):
        assert list(entry.to_dict().items()) == list(raw.items())
        assert entry.id == raw["id"] and entry.verdict == raw["verdict"]
        assert isinstance(entry.adjusted_verdict, Verdict)
    newer = {**stored[0], "looks": [1, 2]}
    newer = {k: newer[k] for k in ["id", "looks", *[k for k in stored[0] if k != "id"]]}
    entry = LedgerEntry.from_dict(newer)
    assert entry.looks == [1, 2] and list(entry.to_dict()) == list(newer)
    try:
        entry.no_such_field  # noqa: B018
    except AttributeError as exc:
        assert "no_such_field" in str(exc)
    else:
        raise AssertionError("an unknown field must raise AttributeError")


def test_a_question_is_answered_by_the_verdicts_of_its_claims():
    from icil_paper.verdict_words import answer

    H, N, I, F, R = Verdict
    assert answer([H, H]) == "Yes" and answer([N]) == "No"
    assert answer([I, F]) == "Not decided at this scale"
    assert answer([R, R]) == "Not run yet"
    assert answer([H, N, I]) == "In part (1 holds, 1 does not hold, 1 is inconclusive)"
    assert answer([H, I, R]).startswith("In part (1 holds")


def test_the_introduction_answers_the_three_questions_with_their_numbers():
    """Every claim that decides or stands beside a question is in the committed ledger with
    its number (what chapter 0 glues into the introduction), and the answer word follows
    the verdicts after Holm."""
    from icil_paper.book.report import QUESTIONS, answering_ledger
    from icil_paper.config import get_preset
    from icil_paper.paper import CLAIM_LABELS, claims
    from icil_paper.tables.claims import load_ledger
    from icil_paper.verdict_words import answer

    path = Path(__file__).resolve().parents[1] / "results" / "reference" / "claims.json"
    assert {e.id for e in load_ledger(path)} == set(CLAIM_LABELS)
    ledger = {e.id: e for e in answering_ledger(path)[0]}  # the older code's while none ran
    assert {c.id for c in claims(get_preset("reference"))} == set(CLAIM_LABELS)
    for question in QUESTIONS:
        assert answer([ledger[c].adjusted_verdict for c in question.decides])
        for claim_id in (*question.decides, *question.beside):
            e = ledger[claim_id]
            assert not e.run or (e.ours is not None and len(e.ci) == 2)
    assert [q.key for q in QUESTIONS] == ["Q1", "Q2", "Q3"]


def test_forest_plot_rows_say_what_each_claim_says_beside_its_id():
    import matplotlib

    matplotlib.use("Agg")
    from icil_paper.book.report import forest_plot, row_label
    from icil_paper.paper import CLAIM_LABELS
    from icil_paper.tables.claims import load_ledger

    path = Path(__file__).resolve().parents[1] / "results" / "reference" / "claims.json"
    ledger = load_ledger(path)
    fig = forest_plot(ledger)
    shown = [t.get_text() for ax in fig.axes for t in ax.get_yticklabels()]
    assert sorted(shown) == sorted(row_label(e) for e in ledger)
    assert row_label(ledger[0]) == f"{CLAIM_LABELS[ledger[0].id]}  [{ledger[0].id}]"


# --------------------------------------------------------------------------- the library writes no prose
ENGLISH_CEILING = 10
"""The most functions in `src/icil_paper` whose job is English (`english_functions`): 69 before
issue 56, 10 since (the vocabulary module counting as one place, 11 in all): command-line
reports and messages of the loaders. A new one fails the test: write the sentence in the
chapter and glue its numbers."""

_SENTENCE = __import__("re").compile(r"[A-Za-z]{2,}(?:[ ,;:()]+[A-Za-z'-]+){4,}")
"""Five or more words in a row: a phrase of a sentence, not a label or a key."""
_TEXT_RETURN = __import__("re").compile(
    r"^(str|str \| None|None \| str|list\[str\]|tuple\[str, str\]|.*Markdown.*)$")
_NOT_PROSE = {"warn", "warning", "error", "info", "debug", "exit", "ExtensionError"}


def _phrases(node):
    """The string literals and f-strings of a function's body that the function returns or
    shows: outside its docstring, nested definitions, `raise` and log or warning calls."""
    import ast

    if isinstance(node, ast.Raise):
        return
    if isinstance(node, ast.Call) and ast.unparse(node.func).split(".")[-1] in _NOT_PROSE:
        return
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        yield node.value
        return
    if isinstance(node, ast.JoinedStr):
        yield "".join(v.value if isinstance(v, ast.Constant) else " x " for v in node.values)
        return
    for child in ast.iter_child_nodes(node):
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            continue
        if isinstance(child, ast.Expr) and isinstance(child.value, ast.Constant):
            continue  # a docstring
        yield from _phrases(child)


def english_functions(root: Path) -> list[str]:
    """"file:line:name" of each function under `root` whose job is English: it returns text
    (`-> str`, a list of them, Markdown) or shows Markdown, and holds a literal phrase of five
    or more words. A message naming a problem (`*_problem`, `*_problems`, a `raise`) is not counted, nor
    is `verdict_words`, the one vocabulary (it counts as one place)."""
    import ast

    found = []
    for path in sorted(root.rglob("*.py")):
        if path.name == "verdict_words.py":
            continue
        for fn in ast.walk(ast.parse(path.read_text())):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            returns = ast.unparse(fn.returns) if fn.returns is not None else ""
            shows = any(isinstance(n, ast.Call) and ast.unparse(n.func) in
                        {"Markdown", "collapsed_markdown"} for n in ast.walk(fn))
            if fn.name.endswith(("problem", "problems")) or not (_TEXT_RETURN.match(returns) or shows):
                continue
            if any(_SENTENCE.search(t) for t in _phrases(fn)):
                found.append(f"{path.relative_to(root)}:{fn.lineno}:{fn.name}")
    return found


def test_the_count_of_english_functions_finds_prose_and_skips_messages(tmp_path):
    (tmp_path / "a.py").write_text(
        'def finding(x) -> str:\n    """Docstrings are not counted at all here."""\n'
        '    return f"the bound held for {x} of the encoders we trained"\n\n'
        'def label(x) -> str:\n    return f"{x} seeds"\n\n'
        'def check(x) -> str:\n    raise ValueError("this is an error and not a finding")\n\n'
        'def path_problem(p) -> str | None:\n    return "the folder is missing: create it first"\n')
    assert english_functions(tmp_path) == ["a.py:1:finding"]


def test_the_library_keeps_few_functions_that_write_english():
    root = Path(__file__).resolve().parents[1] / "src" / "icil_paper"
    found = english_functions(root)
    assert len(found) <= ENGLISH_CEILING, (
        f"{len(found)} functions write English (at most {ENGLISH_CEILING}):\n"
        + "\n".join(found))
