"""Chapters call and show: a chapter's code cells are short (they call a library function
and show what it returns), no cell builds a sentence from numbers inline, and the functions
the chapters call work on the committed reference records or on small made-up input."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHAPTERS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.py"))

CELL_LIMIT = 12
"""The most lines of code a chapter's code cell may hold (import statements, comments and
blank lines not counted): enough to call a few functions and show their results."""

TEACHES = "# teaches:"
"""The first line of a cell that teaches the method in code and may be longer."""
TEACHING_CELLS = {
    "02_icrt_preliminaries.py": ["Eq. 1's token layout, read from a real batch"],
    "03_lipschitz_normalization.py": ["Eq. 4 and the bound of Eq. 5, run"],
    "05_action_tokenizers.py": ["each tokenizer's encode and decode, run"],
    "06_table1_kitchen.py": ["one training step and the rollout loop, at toy scale"],
}
"""Every cell allowed to be longer, by chapter: the text after its `# teaches:` tag. A tag
that is not listed here fails the test, so that the exemption does not spread."""


# --------------------------------------------------------------------------- the rules
def code_cells(path: Path) -> list[str]:
    """The sources of a py:percent chapter's code cells, in order, without its glue cells
    (`glue_cell`)."""
    import jupytext

    return [c.source for c in jupytext.read(path).cells
            if c.cell_type == "code" and not glue_cell(c)]


def glue_cell(cell) -> bool:
    """A removed cell that computes the numbers the prose below it pastes (MyST-NB's `glue`):
    the chapter's findings are that prose, so the cell may be as long as it needs."""
    return "remove-cell" in cell.metadata.get("tags", ()) and "glue(" in cell.source


def code_lines(source: str) -> int:
    """Lines of a cell that hold code: not blank, not a comment, not part of an import."""
    imports = {line for node in ast.walk(ast.parse(source))
               if isinstance(node, (ast.Import, ast.ImportFrom))
               for line in range(node.lineno, node.end_lineno + 1)}
    return sum(1 for i, line in enumerate(source.splitlines(), start=1)
               if line.strip() and not line.lstrip().startswith("#") and i not in imports)


def _text(node: ast.AST) -> bool:
    """A string built from pieces: an f-string, a literal, or a sum of them."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _text(node.left) or _text(node.right)
    return isinstance(node, ast.JoinedStr) or (isinstance(node, ast.Constant)
                                                and isinstance(node.value, str))


def sentences_built_inline(source: str) -> list[int]:
    """First lines of the f-strings, and sums of strings holding an f-string, that span more
    than one line of a cell: a sentence made from numbers in the chapter."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        spans = node.end_lineno > node.lineno if hasattr(node, "end_lineno") else False
        if isinstance(node, ast.JoinedStr) and spans:
            found.add(node.lineno)
        elif (isinstance(node, ast.BinOp) and spans and _text(node)
              and any(isinstance(n, ast.JoinedStr) for n in ast.walk(node))):
            found.add(node.lineno)
    return sorted(found)


def teaching_tag(source: str) -> str | None:
    """The text after a cell's `# teaches:` tag (its first line), else None."""
    first = source.lstrip("\n").splitlines()[0] if source.strip() else ""
    return first[len(TEACHES):].strip() if first.startswith(TEACHES) else None


def problems(path: Path) -> list[str]:
    """What breaks the rules in one chapter: each long untagged cell, each tag not in
    `TEACHING_CELLS`, each sentence built over several lines."""
    out = []
    allowed = TEACHING_CELLS.get(path.name, [])
    for k, source in enumerate(code_cells(path), start=1):
        tag, n = teaching_tag(source), code_lines(source)
        if tag is not None and tag not in allowed:
            out.append(f"{path.name} cell {k}: '{TEACHES} {tag}' is not a listed teaching cell")
        if tag is None and n > CELL_LIMIT:
            out.append(f"{path.name} cell {k}: {n} lines of code (at most {CELL_LIMIT}): move "
                       f"the logic into a library function and call it")
        for line in sentences_built_inline(source):
            out.append(f"{path.name} cell {k}, line {line}: a sentence built from numbers "
                       f"over several lines: write it in the chapter's prose and glue the numbers")
    return out


# --------------------------------------------------------------------------- the chapters
def test_the_rules_find_long_cells_sentences_built_inline_and_unlisted_tags(tmp_path):
    short = "from x import (\n    a,\n    b,\n)\n\n# a comment\nshow(a(b))\n"
    assert code_lines(short) == 1
    assert sentences_built_inline('print(f"one line {x}")\nprint("a " + f(x))\n') == []
    assert sentences_built_inline('print(f"{x} and "\n      f"{y}")\n') == [1]
    assert sentences_built_inline('s = ("plain " +\n     f"{x}")\n') == [1]
    assert sentences_built_inline('s = ("static text, "\n     "no numbers")\n') == []
    long = "\n".join(f"x{i} = {i}" for i in range(CELL_LIMIT + 1))
    chapter = tmp_path / "02_icrt_preliminaries.py"
    chapter.write_text(f"# %%\n{long}\n\n# %%\n{TEACHES} Eq. 1's token layout, read from a "
                       f"real batch\n{long}\n\n# %%\n{TEACHES} something else\n{long}\n")
    found = problems(chapter)
    assert len(found) == 2, found
    assert "cell 1: 13 lines of code" in found[0] and "'# teaches: something" in found[1]


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_a_chapter_calls_the_library_and_shows_what_it_returns(path):
    """Each code cell is short or a listed teaching cell, and builds no sentence over
    several lines: findings are the chapter's prose, with computed numbers glued in."""
    assert not problems(path)


def test_every_listed_teaching_cell_exists():
    for name, tags in TEACHING_CELLS.items():
        found = [teaching_tag(s) for s in code_cells(ROOT / "notebooks" / name)]
        assert [t for t in found if t is not None] == tags, name


# --------------------------------------------------------------------------- the source shown
SOURCE_SHOWN = {
    "02_icrt_preliminaries.py": {"src/icil_paper/policies/icrt.py": ["ICRT.sequence"],
                                 "src/icil_paper/policies/transformer.py": ["causal_mask"]},
    "03_lipschitz_normalization.py": {"src/icil_paper/tokenizers/lipschitz_linear.py": [
        "LipschitzLinear.normalized_weight", "LipschitzLinear.forward", "lipschitz_loss"]},
    "05_action_tokenizers.py": {
        "src/icil_paper/tokenizers/mlp.py": ["MLPTokenizer._forward"],
        "src/icil_paper/tokenizers/bin.py": ["BinTokenizer._forward"],
        "src/icil_paper/tokenizers/fast.py": ["FASTTokenizer._forward"],
        "src/icil_paper/tokenizers/vq.py": ["VQTokenizer.quantize", "VQTokenizer._forward"],
        "src/icil_paper/tokenizers/lfq.py": ["LFQTokenizer._forward"]},
    "06_table1_kitchen.py": {"src/icil_paper/train/loop.py": ["_step"],
                             "src/icil_paper/eval/rollouts.py": ["rollout_batch"]},
}
"""The library source each method chapter shows (issue 56): the step it explains, included
from the module at build time by MyST's `literalinclude` with `:pyobject:`, never copied."""

def included_sources(path: Path) -> dict[str, list[str]]:
    """{file under the repository: [the :pyobject: names]} of a chapter's literalincludes."""
    text = "\n".join(line.removeprefix("# ").removeprefix("#") if line.startswith("#") else line
                     for line in path.read_text().splitlines()) + "\n"
    found: dict[str, list[str]] = {}
    for m in re.finditer(r"```\{literalinclude\}\s+/(\S+)\n((?::[^\n]*\n)*)", text):
        options = dict(re.findall(r":(\w+):\s*(.*)", m.group(2)))
        found.setdefault(m.group(1), []).append(options.get("pyobject", ""))
    return found


def defined_names(path: Path) -> set[str]:
    """Module-level functions and classes of a Python file, and `Class.method` names."""
    names = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        if isinstance(node, ast.ClassDef):
            names |= {f"{node.name}.{n.name}" for n in node.body
                      if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
    return names


def test_included_sources_reads_literalincludes(tmp_path):
    chapter = tmp_path / "99_x.py"
    chapter.write_text("# %% [markdown]\n# ```{literalinclude} /src/a.py\n# :pyobject: A.f\n"
                       "# :caption: a\n# ```\n")
    assert included_sources(chapter) == {"src/a.py": ["A.f"]}
    assert included_sources(tmp_path / "99_x.py") != {"src/a.py": ["B.g"]}


@pytest.mark.parametrize("name", sorted(SOURCE_SHOWN))
def test_method_chapters_include_the_library_source_of_their_step(name):
    """Chapters 02, 03, 05 and 06 show the source of the step they explain, by
    `literalinclude` of the module itself, and every object they name exists there."""
    shown = included_sources(ROOT / "notebooks" / name)
    for file, objects in SOURCE_SHOWN[name].items():
        assert set(objects) <= set(shown.get(file, [])), (name, file, shown)
    for file, objects in shown.items():
        assert (ROOT / file).is_file(), file
        missing = set(objects) - defined_names(ROOT / file)
        assert not missing, f"{name}: {file} defines no {missing}"


GLUE_ROLE = re.compile(r"\{glue(?::\w+)?\}(?:`([^`:]+)|\s+([\w-]+))")


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_every_pasted_number_is_glued_by_its_chapter(path):
    """Each `{glue:...}` role of a chapter's prose names a key its own cells glue."""
    text = path.read_text()
    glued = [re.compile(re.sub(r"\\\{[^}]*\\\}", ".+", re.escape(k)) + "$")
             for k in re.findall(r"""glue\(\s*f?["']([^"']+)["']""", text)]
    pasted = {k.strip() for pair in GLUE_ROLE.findall(text) for k in pair
              if k.strip() and "::" not in k}
    missing = sorted(k for k in pasted if not any(g.match(k) for g in glued))
    assert not missing, f"pasted but never glued: {missing}"


# --------------------------------------------------------------------------- what the cells call
@pytest.fixture()
def shown(monkeypatch):
    """What the book's display helpers display, in order (instead of a notebook's output)."""
    import IPython.display

    from icil_paper.book import components

    out = []
    for module in (IPython.display, components):
        monkeypatch.setattr(module, "display", out.append)
    return out


def _success(rates, tasks: int = 2, episodes: int = 10):
    """A success cell: seed s succeeds in a share rates[s] of every task's episodes."""
    import numpy as np

    from icil_paper import stats
    from icil_paper.tables.assemble import EntryResult

    data = np.zeros((len(rates), tasks, episodes), bool)
    for s, rate in enumerate(rates):
        data[s, :, :round(rate * episodes)] = True
    return EntryResult(stats.success_rate(data), data, 0)


def _smoothness(energy: float, codes: int | None = 4):
    """A smoothness cell of 3 seeds x 5 trajectories near `energy`, with its features
    records (seed 0's holding the view of Fig. 4)."""
    import numpy as np

    from icil_paper import stats
    from icil_paper.tables.assemble import EntryResult

    scores = energy + np.arange(15, dtype=float).reshape(3, 5) / 10
    metrics = [{"codes_used": codes, "n_features": 40, "view_actions": [[0.0] * 7] * 6}
               for _ in range(3)]
    return EntryResult(stats.score_mean(scores), scores, 0,
                      {"standardized_estimate": stats.score_mean(scores / 2),
                       "latent_scale": [0.5, 0.7, 0.9], "metrics": metrics})


def _table(table_id: str, cells) -> object:
    """A table of the smoke preset's rows with the given cells ({(row, column): cell})."""
    from icil_paper.config import get_preset
    from icil_paper.paper import table_spec
    from icil_paper.tables.assemble import TableResult

    return TableResult(table_spec(get_preset("smoke"), table_id), dict(cells), "smoke")


def test_display_helpers_name_each_source_and_say_when_there_is_nothing(shown):
    import pandas as pd

    from icil_paper.tables.display import show_frame_or, show_sources, source_paragraph

    result = _table("prompt", {})
    assert source_paragraph("this build", result, lambda r: "a.", lambda r: "b.") == (
        "**the quick run (smoke).** a. b.")
    assert source_paragraph("smoke run", result, lambda r: "- x", sep="\n\n") == (
        "**smoke run.**\n\n- x")
    show_sources({"reference run": result, "this build": result}, lambda r: r.preset)
    assert [m.data for m in shown] == ["**our run (smoke).** smoke",
                                       "**the quick run (smoke).** smoke"]
    frame = pd.DataFrame({"a": [1]})
    show_frame_or(frame, "none")
    show_frame_or(None, "*none*")
    show_frame_or(frame.iloc[:0], "*empty*")
    assert shown[2] is frame and [m.data for m in shown[3:]] == ["*none*", "*empty*"]


def test_chapter_0_ledgers_write_this_builds_and_read_the_committed_design(shown):
    import os
    from pathlib import Path

    from icil_paper.book.report import chapter_ledgers, committed_design, reference_ledger
    from icil_paper.config import get_preset

    ledgers = chapter_ledgers(get_preset("smoke"))
    assert list(ledgers) == ["reference run", "this build"]
    assert (Path(os.environ["ICIL_RESULTS"]) / "smoke" / "claims.json").is_file()
    assert not (Path(os.environ["ICIL_RESULTS"]) / "reference" / "claims.json").exists()
    assert reference_ledger(ledgers) is ledgers["reference run"][1]
    assert committed_design("I") == {"protocol": "metaworld", "seeds": {}}  # no record here


def test_the_committed_design_is_read_from_design_json(monkeypatch):
    import json

    from icil_paper.book.report import committed_design

    monkeypatch.setenv("ICIL_RESULTS", str(ROOT / "results"))
    design = committed_design("I")
    record = json.loads((ROOT / "results" / "reference" / "design.json").read_text())
    assert design["protocol"] == record.get("protocol", "metaworld")
    reached = {}
    for look in record["looks"]:
        for name, n in look["rows"].items():
            if name.startswith("I:"):
                reached[name[2:]] = max(reached.get(name[2:], 0), n)
    assert design["seeds"] == reached and reached


def test_chapter_1_lists_every_preset_field_with_its_docstring():
    from icil_paper.book.report import config_fields, preset_fields
    from icil_paper.config import get_preset

    preset = get_preset("smoke")
    frame = preset_fields(preset)
    assert frame.loc["train.steps", "value"] == str(preset.train.steps)
    assert frame.loc["train.steps", "meaning"]  # every field has its docstring
    assert {"policies.icrt.d_model", "tokenizers.lipvq.codebook_size"} <= set(frame.index)
    nested = [name for name, _, _ in config_fields(preset.tokenizers.lipvq, "lipvq")]
    assert any(name.count(".") > 1 for name in nested)  # the Lipschitz options, expanded


def test_chapter_2_counts_the_tokens_the_loss_reaches_and_replays_a_stored_episode(
        monkeypatch):
    from types import SimpleNamespace

    import numpy as np
    import torch
    from matplotlib.figure import Figure

    from icil_paper.book import method

    # one sequence: 2 prompt tokens, a padded one, then query obs, action, obs, action
    roles = {"segment": torch.tensor([[0, 0, 0, 1, 1, 1, 1]]),
             "valid": torch.tensor([[True, True, False, True, True, True, True]]),
             "supervised": torch.tensor([[False, False, False, True, False, True, False]])}
    grads = torch.tensor([[0.0, 0.0, 0.0, 0.5, 0.0, 0.2, 0.0]])
    coverage = method.loss_coverage(roles, grads)
    assert coverage == {"query_reached": 2, "query": 2, "prompt_reached": 0, "prompt": 2,
                        "unsupervised_reached": 0}
    grads[0, 1] = 1.0  # a loss that leaked onto the prompt is counted as such
    assert method.loss_coverage(roles, grads)["prompt_reached"] == 1
    assert method.loss_coverage(roles, grads)["unsupervised_reached"] == 1
    assert isinstance(method.loss_gradient_figure(grads), Figure)

    batch = {"prompt_valid": torch.tensor([[True, True], [True, False]])}
    mask = np.tril(np.ones((6, 6)))
    assert isinstance(method.attention_mask_figure(mask, batch, 1), Figure)

    study = {"train": {"steps": 5, "loss": [2.0, 1.0]}, "eval": {"successes": 1, "episodes": 2}}
    m = method.study_metrics(study)
    assert m["loss"] == [2.0, 1.0] and m["successes"] == 1 and m["train"]["steps"] == 5
    m.update(success_rate=0.5, ci_low=0.1, ci_high=0.9, mean_steps=40.2, loss_steps=[0, 5],
             action_l1=[1.0, 0.5])
    assert isinstance(method.training_figure(m, "t"), Figure)
    demos = [SimpleNamespace(actions=np.zeros((n, 7))) for n in (30, 50)]

    episodes = [{"episode": 0, "seed": 7, "prompt": [1], "success": False, "steps": 9},
                {"episode": 1, "seed": 8, "prompt": [0], "success": True, "steps": 4}]
    assert method.shown_episode(episodes) is episodes[1]
    assert method.shown_episode(episodes[:1]) is episodes[0]  # none succeeded: the first
    closed = []
    env = SimpleNamespace(close=lambda: closed.append(True))
    monkeypatch.setattr(method, "make_env", lambda task, obs, seed: env)

    def rollout(policy, env_, seed, prompt, max_steps, keep_trace):
        assert env_ is env and seed == 8 and prompt == [demos[0]] and max_steps == 60
        return {"success": True, "steps": 4, "obs": [{"proprio": np.zeros(9)}] * 4,
                "actions": np.zeros((4, 7))}

    monkeypatch.setattr(method, "rollout_policy", rollout)
    episode, prompt, trace = method.replay_episode("policy", demos, episodes, "t", 60)
    assert episode is episodes[1] and prompt == [demos[0]] and closed == [True]
    demo = SimpleNamespace(obs={"proprio": np.zeros((5, 9))}, actions=np.zeros((5, 7)))
    assert isinstance(method.rollout_figure(trace, demo), Figure)


def _lipschitz_record(bound: float, empirical: float) -> dict:
    return {"bound_softplus_product": bound, "bound_inf": bound, "bound_2": 1.0,
            "empirical_inf_r0.1": empirical / 2, "empirical_inf_r1": empirical,
            "empirical_2_r0.1": 0.3, "empirical_2_r1": 0.4, "reconstruction_mse": 0.01,
            "latent_least_energy": 0.2, "latent_least_energy_standardized": 0.3,
            "latent_scale": 0.5, "c_history": [[1.0, 2.0], [1.1, 2.1], [1.2, 2.2]],
            "history_step": [0, 50, 100]}


def test_chapter_3_table_and_figures_read_each_encoders_largest_estimate():
    from matplotlib.figure import Figure

    from icil_paper.book.method import (
        bound_figure,
        bound_history_figure,
        empirical_constant,
        lipschitz_frame,
    )

    radii = (0.1, 1.0)
    records = {"lipvq (paper)": _lipschitz_record(2.0, 1.5),
               "vq (no normalization)": _lipschitz_record(9.0, 3.0)}
    assert empirical_constant(records["lipvq (paper)"], radii) == 1.5
    assert empirical_constant(records["lipvq (paper)"], radii, "2") == 0.4
    frame = lipschitz_frame(records, radii)
    assert list(frame.index) == list(records)
    assert frame.loc["vq (no normalization)", "empirical (inf)"] == 3.0
    assert frame.loc["lipvq (paper)", "bound (inf)"] == 2.0
    fig = bound_figure(records, radii)
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == list(records)
    history = bound_history_figure(records["lipvq (paper)"], "bounds")
    assert isinstance(history, Figure) and len(history.axes[0].lines) == 2  # one per layer


def _demo(task: str, source: str, steps: int, attempt: int):
    import numpy as np

    from icil_paper.data.hdf5 import Demo

    rng = np.random.default_rng(steps)
    actions = rng.uniform(-1, 1, (steps, 7)).astype(np.float32)
    return Demo(actions=actions, obs={"proprio": np.zeros((steps, 9), np.float32),
                                      "object": np.zeros((steps, 3), np.float32)},
                task=task, source=source, meta={"attempt": attempt})


def test_chapter_4_tables_and_figures_from_small_data_sets(tmp_path, shown):
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.figure import Figure

    from icil_paper.book import components as c
    from icil_paper.data.hdf5 import write_demos

    tasks = c.data_tasks()
    assert tasks == [t for t in c.DATA_TASKS if t in tasks] and tasks
    registry = c.task_registry()
    assert {"kitchen/open_drawer", "maniskill/pick_cube"} <= set(registry.task)

    task = "kitchen/open_drawer"
    data_sets = {}
    for source, attempts in (("generated", (0, 0, 1)), ("human", (1, 1, 2))):
        demos = [_demo(task, source, 20 + 10 * i, a) for i, a in enumerate(attempts)]
        data_sets[task, source] = write_demos(tmp_path / f"{source}.hdf5", demos)
    kept = c.keep_rates(data_sets, limit=3)
    assert kept.loc[task, c.KEPT_COLUMN.format(source="generated")] == pytest.approx(3 / 4)
    assert kept.loc[task, c.KEPT_COLUMN.format(source="human")] == pytest.approx(3 / 7)
    demos = c.load_data_sets(data_sets, [task], limit=2)
    assert {k: len(v) for k, v in demos.items()} == {(task, "generated"): 2, (task, "human"): 2}
    stats = c.demo_stats(demos)
    summary = c.demo_summary(demos, stats)
    assert summary.loc[(task, "human"), "mean_length"] == 25
    assert summary.loc[(task, "generated"), "keep_rate"] == pytest.approx(1.0)
    c.show_demo_summary(summary)
    assert "least energy / step" in shown[0].columns
    assert isinstance(c.demos_figure(demos, stats, [task]), Figure)

    plt.imsave(tmp_path / "frame.png", np.zeros((4, 4, 3)))
    showcase = {task: {"task": task, "instruction": "open the drawer", "success": True,
                       "length": 30, "horizon": 200, "seconds": 1.0, "extra": 0,
                       "frame": str(tmp_path / "frame.png"), "rrd": "a.rrd",
                       "picture": "a.png"}}
    assert list(c.showcase_frame(showcase).columns) == c.SHOWCASE_COLUMNS
    assert c.showcase_recordings(showcase) == {task: ("a.rrd", "a.png")}
    assert isinstance(c.first_frames_figure(showcase), Figure)
    assert c.zero_shot_lines().startswith(("zero-shot: train on", "kitchen suite unavailable"))


def test_chapter_5_tables_and_figure_from_made_up_seed_records():
    import numpy as np
    from matplotlib.figure import Figure

    from icil_paper.book.components import (
        paper_tokenizer_smoothness,
        smoothness_figure,
        tokenizer_frames,
    )
    from icil_paper.book.studies import SeedRecords
    from icil_paper.paper.table_iii import TABLE_III_SMOOTHNESS

    paper = paper_tokenizer_smoothness()
    assert paper["lipvq"] == TABLE_III_SMOOTHNESS["icrt+lipvq"] and "icrt+lipvq" not in paper

    def seed(energy, s):
        scores = (energy + 0.01 * s + 0.001 * np.arange(10)).tolist()
        return {"least_energy_per_trajectory": scores,
                "least_energy_standardized_per_trajectory": scores, "latent_scale": 0.5,
                "usage": 0.25, "codebook_size": 16, "reconstruction_mse": 0.01,
                "decode_mse": 0.02, "perplexity": 3.0, "tokens_per_step": 1.0,
                "encode_actions_per_s": 1000.0}

    seeds = SeedRecords({"lipvq": [seed(1.0, s) for s in range(3)],
                         "mine": [seed(2.0, s) for s in range(3)]})
    properties, smoothness = tokenizer_frames(seeds, paper)
    assert list(properties.data.index) == ["lipvq", "mine"]
    assert properties.data.loc["mine", "usage"] == 0.25
    assert smoothness.data.loc["lipvq", "paper least energy"] == paper["lipvq"]
    assert np.isnan(smoothness.data.loc["mine", "paper least energy"])  # not the paper's
    html = smoothness.to_html()
    assert "25.0%" in properties.to_html() and "-" in html
    fig = smoothness_figure(seeds, paper)
    assert isinstance(fig, Figure) and len(fig.axes) == 3


def test_chapters_6_to_8_sentences_and_table_iii_beside_its_standardized_score():
    import numpy as np
    from matplotlib.figure import Figure

    from icil_paper.book import experiments as ex
    smooth = _table("III", {("icrt+vq", "least_energy"): _smoothness(1.0),
                            ("icrt+lipvq", "least_energy"): _smoothness(0.5, codes=None)})
    assert ex.standardized_frame({"this build": _table("III", {})}) is None
    frame = ex.standardized_frame({"this build": smooth})
    assert list(frame.index) == [("the quick run (smoke)", "icrt+vq"),
                                 ("the quick run (smoke)", "icrt+lipvq")]
    row = frame.loc[("the quick run (smoke)", "icrt+vq")]
    assert row["latent scale σ"] == 0.7 and row["codes used"] == 4 and row["features"] == 40
    assert row["raw"] == "1.700 [" + row["raw"].split("[")[1]  # mean of 1.0 + 0.0 ... 1.4
    assert np.isnan(frame.loc[("the quick run (smoke)", "icrt+lipvq"), "codes used"])  # no codes
    paths = {"icrt+vq": [[0.0, 0.0], [1.0, 1.0]], "icrt+lipvq": [[0.0, 1.0], [1.0, 0.0]]}
    fig = ex.tsne_figure({k: np.array(v) for k, v in paths.items()})
    assert isinstance(fig, Figure) and [a.get_title() for a in fig.axes] == ["vq", "lipvq"]
    assert ex.tsne_actions(_table("III", {("icrt+mlp", "least_energy"): _smoothness(1.0)})
                           ).shape == (6, 7)


def test_chapters_10_to_13_sentences_from_made_up_tables():
    from icil_paper.book import experiments as ex
    from icil_paper.stats import Estimate, Verdict

    right, wrong = "right prompt", "another task's prompt"  # the smoke preset's rows
    prompt = {"this build": _table("prompt", {(right, "avg"): _success([0.8, 0.9, 0.7]),
                                              (wrong, "avg"): _success([0.2, 0.3, 0.1])})}
    frame = ex.prompt_frame(prompt)
    first = frame.iloc[0]
    assert frame.index[0][1] == wrong and first.iloc[0].startswith("+0.600 [")
    assert frame.iloc[1].iloc[0] == "not run"  # the truncated prompt has no cells here

    beyond = {"this build": _table("beyond", {("icrt+lipfsq", "avg"): _success([0.5] * 3),
                                              ("icrt+fsq", "avg"): _success([0.5] * 3)})}
    text = ex.eq4_differences(beyond)
    assert [line for line in text.splitlines() if line.startswith("**")] == [
        f"**{a} against {b}**" for a, b in ex.EQ4_PAIRS]
    assert "'icrt+lipfsq' minus 'icrt+fsq' = +0.000" in text

    found = [{"quantity": "q1", "direction": -1, "estimate": None, "verdict": Verdict.NOT_RUN},
             {"quantity": "q2", "direction": +1, "verdict": Verdict.HOLDS,
              "estimate": Estimate(0.2, 0.1, 0.3, 6, "t")}]
    assert ex.comparison_list(found) == (
        "- q1: not run (expected below 0): not run\n"
        "- q2: +0.200 [+0.100, +0.300] (expected above 0): holds")


def test_chapter_14_caps_its_seeds_by_preset():
    from icil_paper.book.own_tokenizer import CHAPTER_MAX_SEEDS
    from icil_paper.tables.compare import MAX_SEEDS

    assert CHAPTER_MAX_SEEDS["small"] <= MAX_SEEDS and "reference" not in CHAPTER_MAX_SEEDS


def test_the_introduction_pastes_only_what_chapter_0_glues():
    """The introduction's answers to Q1-Q3 are pasted from chapter 0 (`doc::key`), and each
    key it names is glued there; its first screen names no claim id."""
    intro = (ROOT / "book" / "intro.md").read_text()
    chapter = (ROOT / "notebooks" / "00_claims_ledger.py").read_text()
    keys = re.findall(r"00_claims_ledger\.py::([\w]+)", intro)
    assert {"Q1_ours", "Q2_ours", "Q3_ours", "Q1_outcome", "run_seeds"} <= set(keys)
    glued = [re.compile(re.sub(r"\\\{[^}]*\\\}", ".+", re.escape(k)) + "$")
             for k in re.findall(r"""glue\(\s*f?["']([^"']+)["']""", chapter)]
    assert all(any(g.match(k) for g in glued) for k in keys), keys
    first_screen = intro[:intro.index("## What the paper claims")]
    assert not re.search(r"\b(?:I|II|III|IV|V|VI|VII)-[a-z]", first_screen)


def test_the_introductions_preset_table_shows_what_each_preset_runs():
    """A preset that evaluates some suites with their own episode counts, or gives its rows
    their seeds in stages, shows those, not the defaults it never runs with."""
    from icil_paper.book.report import preset_table
    from icil_paper.config import PRESET_NAMES, get_preset

    rows = {line.split("|")[1].strip(" `"): [c.strip() for c in line.split("|")[1:-1]]
            for line in preset_table().splitlines()[2:]}
    assert set(rows) == set(PRESET_NAMES)
    for name in PRESET_NAMES:
        tables = get_preset(name).tables
        episodes, seeds = rows[name][4], rows[name][5]
        for suite, n in tables.episodes_by_suite().items():
            assert f"{suite}: {n}" in episodes
        if tables.seed_stages:
            assert all(str(s) in seeds for s in tables.seed_stages) and "stages" in seeds
        else:
            assert seeds == f"{tables.icrt_seeds} / {tables.baseline_seeds}"
    assert get_preset("reference").tables.seed_stages  # the staged case is tested
