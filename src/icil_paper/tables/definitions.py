"""Every table and figure of the paper's Sec. IV as a `TableSpec`, built from a preset.

Numbering follows the paper's source: Table I RoboCasa (our kitchen suite), II ManiSkill,
III smoothness, IV Lipschitz ablation, V sim-to-real (our perturbed Kinova3 stand-in),
VI cross-dataset (MimicGen -> human: our generated -> human-like scenes and sources),
VII zero-shot; Fig. 5 codebook size; and a prompt ablation of our own (does the prompt carry
the task?).

Shared cells: Tables III, IV, V, VI and the prompt ablation reuse Table I's trained
policies (the same RunSpecs; Table VI evaluates them on the `human` scene distribution),
Fig. 5 reuses Table I's LipVQ-VAE run at the preset's codebook size, and the `beyond` table
of our own (tokenizers since the paper) Table I's VQ-VAE and LipVQ-VAE runs, so each policy
is trained once. Every row is evaluated on the same episodes (the same evaluation seed), so
two rows can be compared episode by episode.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

from icil_paper import paper_numbers as paper
from icil_paper.config import (
    PAPER_MANISKILL_TRAIN,
    PAPER_TRAIN,
    Preset,
    TrainConfig,
    bound_travel,
)
from icil_paper.runspec import DataSpec, EvalSpec, RunSpec, eval_spec, run_spec
from icil_paper.seeding import data_set_seed
from icil_paper.tables.spec import Cell, FeatureSpec, Row, TableSpec, Unit

FAMILY_COLUMNS = paper.FAMILIES
"""The seven skill families (columns of Tables I, VI, VII) in the paper's order."""

TABLE_I_ROWS = (("mcr", None), ("act", None), ("bc_transformer", None), ("icrt", "mlp"),
                ("icrt", "bin"), ("icrt", "fast"), ("icrt", "vq"), ("icrt", "lfq"),
                ("icrt", "lipvq"))
"""(policy, tokenizer) of Table I's rows, in the paper's order."""

TABLE_II_ROWS = (("mcr", None), ("act", None), ("bc_transformer", None), ("act", "bin"),
                 ("act", "fast"), ("act", "vq"), ("act", "lfq"), ("act", "lipvq"))
"""Table II: ACT's CVAE action encoder replaced by each tokenizer."""

ICRT_TOKENIZERS = ("mlp", "bin", "fast", "vq", "lfq", "lipvq")
TABLE_IV_ROWS = (("icrt", "mlp"), ("icrt", "lip-mlp"), ("icrt", "vq"), ("icrt", "lipvq"))
TABLE_V_ROWS = (("bc_transformer", None), ("icrt", "bin"), ("icrt", "lipvq"))
MANISKILL_COLUMNS = ("pick_cube", "push_cube", "stack_cube")


def label(policy: str, tokenizer: str | None) -> str:
    return f"{policy}+{tokenizer}" if tokenizer else policy


def families(tasks: Sequence[str]) -> dict[str, list[str]]:
    """Paper column -> our kitchen tasks of that skill family (kept in `tasks`' order)."""
    from icil_paper.sim.kitchen.tasks import FAMILIES, TASK_FAMILIES

    out = {}
    for column, family in zip(FAMILY_COLUMNS, FAMILIES, strict=True):
        out[column] = [t for t in tasks if t in TASK_FAMILIES[family]]
    return out


# --------------------------------------------------------------------------- building blocks
def _runs(preset: Preset, policy: str, tokenizer, tasks: Sequence[str], seeds: int) -> list[RunSpec]:
    """One RunSpec per training seed (preset.seed, preset.seed + 1, ...); seed k trains on
    demonstration set k (`run_spec`), so that seed k of every row shares its data, as it
    shares its evaluation scenes (`_eval`) and, for ICRT, its backbone's initial weights and
    batch order."""
    runs = [run_spec(preset, policy, tokenizer, tasks=tasks, seed=preset.seed + s)
            for s in range(seeds)]
    if policy == "mcr":  # image observations; fewer demonstrations (rendering is costly)
        suite = tasks[0].split("/", 1)[0]
        obs = "rgbd" if suite == "maniskill" else "rgb"
        runs = [run.replace(data=dataclasses.replace(
            run.data, obs=obs, demos_per_task=preset.tables.image_demos_per_task))
            for run in runs]
    return runs


def _eval(preset: Preset, run: RunSpec, task: str, seed_index: int = 0,
          scenes: str = "generated", **prompt) -> EvalSpec:
    """The evaluation of `run` (training seed `seed_index` of its row) on `task`: the
    preset's episodes (MCR's image episodes), the same scenes for every row; with
    `tables.scenes_per_seed`, seed k of every row plays scene set k (evaluation seed
    preset.seed + k), else every seed plays the same scenes. `scenes` is the scene
    distribution (every row's). Prompts only for in-context policies."""
    images = run.policy.type == "mcr"
    episodes = (preset.tables.image_episodes_per_task if images
                else preset.eval.episodes_per_task)
    max_steps = preset.tables.image_max_steps if images else None
    if run.policy.type != "icrt":
        prompt = {}  # no prompt is read: the evaluation is the same as Table I's
    seed = preset.seed + seed_index if preset.tables.scenes_per_seed else None
    return eval_spec(preset, task, episodes=episodes, seed=seed, max_steps=max_steps,
                     scenes=scenes, **prompt)


def table_eval(preset: Preset, run: RunSpec, task: str, seed_index: int = 0) -> EvalSpec:
    """The evaluation every table gives training seed `seed_index` of a row on `task`
    (`_eval`: its episodes, scene set and prompts); the pilots evaluate as the tables do."""
    return _eval(preset, run, task, seed_index)


def _cell(preset: Preset, runs: Sequence[RunSpec], tasks: Sequence[str], **prompt) -> Cell:
    return Cell(tuple(Unit(s, run, _eval(preset, run, task, s, **prompt))
                      for s, run in enumerate(runs) for task in tasks))


def _family_cells(preset: Preset, runs: Sequence[RunSpec], tasks: Sequence[str],
                  **prompt) -> dict[str, Cell]:
    cells = {column: _cell(preset, runs, family_tasks, **prompt)
             for column, family_tasks in families(tasks).items() if family_tasks}
    cells["avg"] = _cell(preset, runs, tasks, **prompt)
    return cells


def row_seeds(preset: Preset, table: str, row: str, default: int) -> int:
    """Training seeds of one row: `tables.row_seeds`' entry for "TABLE:row", else for
    "TABLE:*", else `default`."""
    named = preset.tables.seeds_by_row()
    return named.get(f"{table}:{row}", named.get(f"{table}:*", default))


def table_i_seeds(preset: Preset, policy: str, tokenizer: str | None) -> int:
    """Training seeds of one Table I row (and of every table that shares its runs)."""
    default = preset.tables.icrt_seeds if policy == "icrt" else preset.tables.baseline_seeds
    return row_seeds(preset, "I", label(policy, tokenizer), default)


def table_i_runs(preset: Preset, policy: str, tokenizer) -> list[RunSpec]:
    """The runs of one Table I row (shared by Tables III, IV, V, VI and the prompt ablation)."""
    return _runs(preset, policy, tokenizer, preset.data.kitchen_tasks,
                 table_i_seeds(preset, policy, tokenizer))


# --------------------------------------------------------------------------- the tables
def table_i(preset: Preset) -> TableSpec:
    tasks = preset.data.kitchen_tasks
    rows = []
    for p, t in TABLE_I_ROWS:
        runs = table_i_runs(preset, p, t)
        rows.append(Row(label(p, t), _with_codebook(preset, _family_cells(preset, runs, tasks),
                                                    runs),
                        paper.TABLE_I_ROBOCASA[label(p, t)]))
    return TableSpec("I", "Robotic manipulation results on RoboCasa (our kitchen suite)",
                     (*FAMILY_COLUMNS, "avg"), tuple(rows), beside=("features",), note=(
                         "One multi-task policy per row, trained on the generated demonstrations "
                         "of all kitchen tasks and evaluated per task; ICRT prompts come from the "
                         "generated data sets. avg is the mean over tasks. Beside the table, "
                         "the codebook rows' `features` (Table III's measurement) give their "
                         "codebook use per seed."))


def maniskill_settings(preset: Preset) -> tuple[int, int, int]:
    """Table II's state-based rows: (demonstrations per task, training steps, episodes per
    task), the preset's `tables.maniskill_*` where set, else its shared values."""
    t = preset.tables
    return (t.maniskill_demos_per_task or preset.data.demos_per_task,
            t.maniskill_steps or preset.train.steps,
            t.maniskill_episodes_per_task or preset.eval.episodes_per_task)


def maniskill_tokenizer(run: RunSpec, train: TrainConfig):
    """`run`'s tokenizer for Table II's training `train`: a Lipschitz tokenizer's bounds get
    the learning-rate multiple that lets them travel, relative to the paper's 30K ManiSkill
    iterations, as far as the preset's multiple lets them in its kitchen training relative
    to the paper's 500K (`config.matching_c_lr_scale`); every other tokenizer is unchanged."""
    tok = run.tokenizer
    options = getattr(tok, "lipschitz", None)
    lipschitz = getattr(tok, "norm", "lipschitz").startswith("lipschitz")  # lip-mlp: always
    if options is None or not lipschitz or train == run.train:
        return tok
    factor = (bound_travel(run.train) / bound_travel(train)
              * bound_travel(PAPER_MANISKILL_TRAIN) / bound_travel(PAPER_TRAIN))
    return dataclasses.replace(tok, lipschitz=dataclasses.replace(
        options, c_lr_scale=round(options.c_lr_scale * factor, 3)))


def table_ii(preset: Preset) -> TableSpec:
    demos, steps, episodes = maniskill_settings(preset)
    evaluated = preset.replace(eval={"episodes_per_task": episodes})  # MCR: image episodes

    def state_run(run: RunSpec) -> RunSpec:  # MCR's image runs keep their data and steps
        if run.policy.type == "mcr":
            return run
        train = dataclasses.replace(run.train, steps=steps)
        return run.replace(data=dataclasses.replace(run.data, demos_per_task=demos),
                           train=train, tokenizer=maniskill_tokenizer(run, train))

    rows = []
    for policy, tokenizer in TABLE_II_ROWS:
        cells = {}
        per_task = []
        for column, task in zip(MANISKILL_COLUMNS, preset.data.maniskill_tasks, strict=False):
            seeds = row_seeds(preset, "II", label(policy, tokenizer), 1)
            runs = [state_run(run) for run in _runs(preset, policy, tokenizer, [task], seeds)]
            cells[column] = _cell(evaluated, runs, [task])
            per_task += list(cells[column].units)
        cells["avg"] = Cell(tuple(per_task))
        rows.append(Row(label(policy, tokenizer), cells,
                        paper.TABLE_II_MANISKILL[label(policy, tokenizer)]))
    return TableSpec("II", "Results on ManiSkill", (*MANISKILL_COLUMNS, "avg"), tuple(rows),
                     note=("One policy per task (as ManiSkill's baselines), trained on the "
                           f"motion planner's {demos} demonstrations per task, converted to "
                           "end-effector deltas (MCR: its image data sets)."))


def feature_spec(preset: Preset, run: RunSpec) -> FeatureSpec:
    """Table III's held-out trajectories for a run trained on the kitchen tasks: the
    `tables.feature_demos_per_task` generated demonstrations after the training ones of
    demonstration set 0 (the preset's data seed), of which `tables.feature_steps` features
    are scored in equal shares per task (`per_task` sampling, `icil_paper.eval.features`).
    Every training seed trains on its own set (`_runs`), so no seed has seen them: set 0's
    runs stop before them and the other seeds' never read set 0. It depends on the run's
    data size only, so every training seed of a row scores the same steps, and every table
    that measures a run (III, the codebook use beside I, IV and Fig. 5, `analysis`,
    `beyond`) shares one record."""
    data = DataSpec(tasks=run.data.tasks, source="generated", obs=run.data.obs,
                    demos_per_task=preset.tables.feature_demos_per_task,
                    seed=data_set_seed(preset.seed, 0))
    return FeatureSpec(data=data, start=run.data.demos_per_task,
                       steps=preset.tables.feature_steps, sampling="per_task")


CODEBOOK_TOKENIZERS = ("vq", "lipvq", "lfq", "fsq", "lipfsq", "rvq", "liprvq")
"""Tokenizers with a learned or fixed codebook (the VQ family): their rows of Tables I, IV
and Fig. 5 carry a `features` cell beside the table, for their codebook use."""


def _features_cell(preset: Preset, runs: Sequence[RunSpec]) -> Cell:
    """One feature measurement per training seed of a row (Table III's units for the same
    runs: the same records)."""
    return Cell(tuple(Unit(s, run, features=feature_spec(preset, run))
                      for s, run in enumerate(runs)))


def _with_codebook(preset: Preset, cells: dict[str, Cell], runs: Sequence[RunSpec]
                   ) -> dict[str, Cell]:
    """`cells`, plus a `features` cell where the runs' tokenizer has a codebook."""
    tokenizer = runs[0].tokenizer
    if tokenizer is not None and tokenizer.type in CODEBOOK_TOKENIZERS:
        cells = {**cells, "features": _features_cell(preset, runs)}
    return cells


def table_iii(preset: Preset) -> TableSpec:
    rows = []
    for tokenizer in ICRT_TOKENIZERS:
        runs = table_i_runs(preset, "icrt", tokenizer)
        units = tuple(Unit(s, run, features=feature_spec(preset, run))
                      for s, run in enumerate(runs))
        rows.append(Row(label("icrt", tokenizer), {"least_energy": Cell(units)},
                        {"least_energy": paper.TABLE_III_SMOOTHNESS[label("icrt", tokenizer)]}))
    return TableSpec("III", "Smoothness of the action tokenizers' latent features",
                     ("least_energy",), tuple(rows), measure="smoothness", note=(
                         "Least energy of the latent features that Table I's trained ICRT "
                         "policies' own tokenizers give held-out generated trajectories."))


def table_iv(preset: Preset) -> TableSpec:
    tasks = preset.data.kitchen_tasks
    rows = []
    for p, t in TABLE_IV_ROWS:
        runs = table_i_runs(preset, p, t)
        rows.append(Row(label(p, t), _with_codebook(preset, {"avg": _cell(preset, runs, tasks)},
                                                    runs),
                        paper.TABLE_IV_LIPSCHITZ[label(p, t)]))
    return TableSpec("IV", "Lipschitz regularization's impact", ("avg",), tuple(rows),
                     beside=("features",),
                     note="Average success over the kitchen tasks; MLP and VQ-VAE rows are "
                          "Table I's. Beside the table, the codebook rows' `features` give "
                          "their codebook use per seed.")


def table_v(preset: Preset) -> TableSpec:
    from icil_paper.data.splits import sim_to_real_pairs

    kinova = sorted(sim_to_real_pairs())
    columns = {"drawers": [t for t in kinova if t.endswith("drawer")],
               "doors": [t for t in kinova if t.endswith("door")]}
    rows = []
    for policy, tokenizer in TABLE_V_ROWS:
        runs = table_i_runs(preset, policy, tokenizer)
        cells = {c: _cell(preset, runs, tasks) for c, tasks in columns.items()}
        cells["avg"] = _cell(preset, runs, kinova)
        rows.append(Row(label(policy, tokenizer), cells,
                        paper.TABLE_V_SIM_TO_REAL[label(policy, tokenizer)]))
    return TableSpec("V", "Sim-to-real success rates (our stand-in: Panda -> perturbed Kinova3)",
                     ("drawers", "doors", "avg"), tuple(rows), note=(
                         "Table I's policies (trained on the Panda kitchen) rolled out on the "
                         "Kinova3 arm with perturbed dynamics and noisy observations, prompted "
                         "with Kinova demonstrations; not a real robot."))


def table_vi(preset: Preset) -> TableSpec:
    """Table I's policies (the same runs) on the kitchen suite's `human` scene distribution,
    every row alike; ICRT's prompts come from the human-like source (whose demonstrations
    are played on those scenes too). Episode i of a task has the same seed as in Table I, so
    each row's change from Table I is measured on paired episodes."""
    tasks = preset.data.kitchen_tasks
    rows = tuple(Row(label(p, t), _family_cells(preset, table_i_runs(preset, p, t), tasks,
                                                scenes="human", prompt_source="human"),
                     paper.TABLE_VI_CROSS_DATASET[label(p, t)]) for p, t in TABLE_I_ROWS)
    return TableSpec("VI", "Cross-dataset robotic manipulation (generated -> human-like)",
                     (*FAMILY_COLUMNS, "avg"), rows, note=(
                         "Table I's policies, trained on the generated demonstrations, "
                         "evaluated on the human-like scene distribution (fixtures placed "
                         "elsewhere on the counter and turned further, free objects further "
                         "from their targets): every row faces the shift. ICRT rows are "
                         "prompted with the human-like source's demonstrations (teleoperation-"
                         "like operator on those scenes). avg is the mean over tasks."))


def table_vii(preset: Preset) -> TableSpec:
    from icil_paper.data.splits import zero_shot_split

    train, held_out = zero_shot_split()
    train = [t for t in train if t in preset.data.kitchen_tasks]
    held_out = [t for t in held_out if t in preset.data.kitchen_tasks]
    rows = []
    for policy, tokenizer in TABLE_I_ROWS:
        seeds = row_seeds(preset, "VII", label(policy, tokenizer), 1)
        runs = _runs(preset, policy, tokenizer, train, seeds)
        rows.append(Row(label(policy, tokenizer), _family_cells(preset, runs, held_out),
                        paper.TABLE_VII_ZERO_SHOT[label(policy, tokenizer)]))
    return TableSpec("VII", "Zero-shot robotic manipulation results", (*FAMILY_COLUMNS, "avg"),
                     tuple(rows), note=(
                         f"Trained on {len(train)} kitchen tasks, evaluated on the {len(held_out)} "
                         "held out (one direction of each two-task family); families without a "
                         "held-out task are n/a."))


def fig5(preset: Preset) -> TableSpec:
    tasks = preset.data.kitchen_tasks
    base = preset.tokenizers.lipvq
    rows = []
    # the sweep is scaled to the preset's model: its i-th size stands beside the paper's
    # i-th (2^8 .. 2^11), whatever their absolute values
    paper_sizes = sorted(paper.FIG5_CODEBOOK_SIZE)
    for i, size in enumerate(sorted(preset.tables.codebook_sizes)):
        tok = dataclasses.replace(base, codebook_size=size)
        seeds = row_seeds(preset, "fig5", str(size), 1)
        if size == base.codebook_size:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", "lipvq"))
        runs = _runs(preset, "icrt", tok, tasks, seeds)
        name = _power_of_two(size)
        paper_size = paper_sizes[i] if i < len(paper_sizes) else None
        if paper_size is not None and paper_size != size:
            name += f" (the paper's {_power_of_two(paper_size)})"
        rows.append(Row(name, _with_codebook(preset, {"avg": _cell(preset, runs, tasks)}, runs),
                        {"avg": paper.FIG5_CODEBOOK_SIZE[paper_size]} if paper_size else {}))
    return TableSpec("fig5", "Impact of LipVQ-VAE's codebook size (Fig. 5)", ("avg",),
                     tuple(rows), beside=("features",), note=(
                         f"ICRT + LipVQ-VAE with codebook sizes {list(preset.tables.codebook_sizes)}"
                         f" (the preset's Table I cell uses {base.codebook_size}). "
                         "Beside the table, each size's `features` give its codebook use."))


def _power_of_two(size: int) -> str:
    """"2^8" for 256; other sizes as they are."""
    exponent = size.bit_length() - 1
    return f"2^{exponent}" if 2**exponent == size else str(size)


def _other_task(task: str, tasks: Sequence[str]) -> str:
    """The task whose prompt stands in as the wrong one: the same fixture's opposite goal
    (open/close, on/off) where there is one, else the next task of the list."""
    suite, name = task.split("/", 1)
    swaps = [f"{suite}/{b}{name[len(a):]}" for a, b in (("open_", "close_"), ("close_", "open_"))
             if name.startswith(a)]
    swaps += [f"{suite}/{name[:-len(a)]}{b}" for a, b in (("_on", "_off"), ("_off", "_on"))
              if name.endswith(a)]
    for candidate in swaps:
        if candidate in tasks:
            return candidate
    return tasks[(list(tasks).index(task) + 1) % len(tasks)]


def prompt_ablation(preset: Preset) -> TableSpec:
    tasks = list(preset.data.kitchen_tasks)
    runs = table_i_runs(preset, "icrt", "lipvq")
    right = _cell(preset, runs, tasks)
    wrong = Cell(tuple(Unit(s, run, _eval(preset, run, task, s,
                                          prompt_task=_other_task(task, tasks)))
                       for s, run in enumerate(runs) for task in tasks))
    short = _cell(preset, runs, tasks, prompt_steps=preset.tables.prompt_steps)
    rows = (Row("right prompt", {"avg": right}),
            Row("another task's prompt", {"avg": wrong}),
            Row(f"first {preset.tables.prompt_steps} prompt steps", {"avg": short}))
    return TableSpec("prompt", "Does the prompt carry the task? (ICRT + LipVQ-VAE)", ("avg",),
                     rows, note=(
                         "Table I's ICRT + LipVQ-VAE with its task's prompt, with the prompt of "
                         "another task (the same fixture's opposite goal where there is one), "
                         "and with only the first steps of its own prompt."))


ANALYSIS_VARIANTS = (
    ("icrt+vq", "vq", {}),
    ("icrt+lipvq (paper)", "lipvq", {}),
    ("gamma = 1", "lipvq", {"lipschitz": {"weight": 1.0}}),
    ("c_l init 1", "lipvq", {"lipschitz": {"c_init": 1.0}}),
    ("c_l at the shared rate", "lipvq", {"lipschitz": {"c_lr_scale": 1.0}}),
    ("Liu et al. init", "lipvq", {"lipschitz": {"weight_init": "liu"}}),
    ("vq + dead-code restart", "vq", {"dead_code_restart": 100}),
    ("lipvq + dead-code restart", "lipvq", {"dead_code_restart": 100}),
    ("lipvq, 32-step random windows", "lipvq", {"_policy": {"query_len": 32,
                                                           "query_start": "random"}}),
)
"""The analysis chapter's rows: (label, tokenizer, changes). Tokenizer changes are fields of
its config (`lipschitz` a nested section); `_policy` changes ICRT's config. The presets'
Lipschitz tokenizers start as their plain twins (nn.Linear's initialisation, c at the
initial largest row sum) and their bounds learn at the multiple of the trainer's rate that
lets them travel as far as in the paper's 500K iterations (`config.matching_c_lr_scale`).
`c_l at the shared rate` is the paper's literal setting at our budget (one rate for every
parameter: the bounds stay within about 0.5 of where they start), and the `Liu et al.
init` row starts from Liu et al.'s weights (8x larger action tokens at step 0
than the plain MLP's), as the paper writes them; chapter 11 measures whether Eq. 4 binds."""


def _variant(preset: Preset, tokenizer: str, changes: dict) -> tuple:
    changes = dict(changes)
    policy = dataclasses.replace(preset.policies.icrt, **changes.pop("_policy", {}))
    tok = preset.tokenizers.get(tokenizer)
    if "lipschitz" in changes:
        changes["lipschitz"] = dataclasses.replace(tok.lipschitz, **changes["lipschitz"])
    return policy, dataclasses.replace(tok, **changes)


def analysis(preset: Preset) -> TableSpec:
    """Is it smoothness? Table IV's cells and variants meant to make Eq. 4 bind (a large
    gamma, small initial bounds, a larger learning rate of the bounds), that remedy codebook
    collapse, and that train on ICRT's own 32-step random windows instead of whole
    episodes; success and the trained encoders' smoothness and Lipschitz facts."""
    tasks = preset.data.kitchen_tasks
    rows = []
    for name, tokenizer, changes in ANALYSIS_VARIANTS:
        policy, tok = _variant(preset, tokenizer, changes)
        seeds = row_seeds(preset, "analysis", name, preset.tables.icrt_seeds)
        if not changes:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", tokenizer))
        runs = [r.replace(policy=policy) for r in _runs(preset, "icrt", tok, tasks, seeds)]
        features = Cell(tuple(Unit(s, run, features=feature_spec(preset, run))
                              for s, run in enumerate(runs)))
        rows.append(Row(name, {"avg": _cell(preset, runs, tasks), "features": features}))
    return TableSpec("analysis", "Is it smoothness? Lipschitz bound, latent scale and collapse",
                     ("avg", "features"), tuple(rows), note=(
                         "ICRT with VQ-VAE and LipVQ-VAE variants on the kitchen suite; "
                         "`features` holds each trained encoder's least energy (raw and "
                         "standardized), latent scale, codes used and Lipschitz facts."))


SINCE_PAPER_TOKENIZERS = ("vq", "lipvq", "fsq", "lipfsq", "rvq", "liprvq", "bspline")
"""ICRT's tokenizers in the `beyond` table: Table I's VQ-VAE and LipVQ-VAE, then FSQ,
residual VQ (each without and with Eq. 4) and B-spline control points."""


def since_paper_seeds(preset: Preset) -> int:
    """Training seeds of every `beyond` row: `tables.since_paper_seeds`, else `icrt_seeds`."""
    return preset.tables.since_paper_seeds or preset.tables.icrt_seeds


def beyond(preset: Preset) -> TableSpec:
    """Tokenizers since the paper: ICRT with each of `SINCE_PAPER_TOKENIZERS` on the kitchen
    suite, Table I's protocol and episodes; success per family and on average, and each
    trained tokenizer's latent features (as in Table III and the analysis table). Its VQ-VAE
    and LipVQ-VAE rows are Table I's policies (the same RunSpecs, trained once), with more
    seeds where `since_paper_seeds` asks for them."""
    tasks = preset.data.kitchen_tasks
    rows = []
    for tokenizer in SINCE_PAPER_TOKENIZERS:
        seeds = row_seeds(preset, "beyond", label("icrt", tokenizer), since_paper_seeds(preset))
        if tokenizer in ICRT_TOKENIZERS:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", tokenizer))
        runs = _runs(preset, "icrt", tokenizer, tasks, seeds)
        cells = _family_cells(preset, runs, tasks)
        cells["features"] = Cell(tuple(Unit(s, run, features=feature_spec(preset, run))
                                       for s, run in enumerate(runs)))
        name = label("icrt", tokenizer)
        rows.append(Row(name, cells, paper.TABLE_I_ROBOCASA.get(name, {})))
    return TableSpec("beyond", "Tokenizers since the paper (our kitchen suite, Table I's protocol)",
                     (*FAMILY_COLUMNS, "avg", "features"), tuple(rows), note=(
                         "ICRT with FSQ, residual VQ (each without and with Eq. 4) and "
                         "B-spline control points beside Table I's VQ-VAE and LipVQ-VAE "
                         "policies, trained and evaluated as Table I's rows (the paper's "
                         "numbers are its Table I's, for those two rows only); `features` "
                         "holds each trained tokenizer's least energy on held-out "
                         "trajectories, its latent scale, codes used and Lipschitz facts."))


TABLES: dict[str, Callable[[Preset], TableSpec]] = {
    "I": table_i, "II": table_ii, "III": table_iii, "IV": table_iv, "V": table_v,
    "VI": table_vi, "VII": table_vii, "fig5": fig5, "prompt": prompt_ablation,
    "analysis": analysis, "beyond": beyond,
}
"""Every table by id, in the order the book shows them."""


def table_spec(preset: Preset, table_id: str) -> TableSpec:
    """The TableSpec of one table (UnknownNameError listing the ids otherwise)."""
    from icil_paper.registry import check_name

    return TABLES[check_name("table", table_id, TABLES)](preset)


# --------------------------------------------------------------------------- the official code
OFFICIAL_PAPER_LIPVQ = "icrt+lipvq (paper)"
OFFICIAL_PAPER_BIN = "icrt+bin (paper)"
OFFICIAL_ROWS = (
    (OFFICIAL_PAPER_LIPVQ, None),
    ("icrt+lipvq (official code)", OFFICIAL_PAPER_LIPVQ),
    ("last layer only", OFFICIAL_PAPER_LIPVQ),
    ("detached latent", OFFICIAL_PAPER_LIPVQ),
    ("no Lipschitz loss", OFFICIAL_PAPER_LIPVQ),
    (OFFICIAL_PAPER_BIN, None),
    ("icrt+bin (official code)", OFFICIAL_PAPER_BIN),
    ("prompts from the minibatch", OFFICIAL_PAPER_LIPVQ),
)
"""The `official` table's rows in order: (label, the paper's row it is compared with; None
for the paper's own rows)."""

OFFICIAL_SINGLE_DIFFERENCES = {
    "last layer only": ("norm", "output_activation", "lipschitz.per_row", "lipschitz.c_init",
                        "lipschitz.weight_init"),
    "detached latent": ("detach_embeddings",),
    "no Lipschitz loss": ("lipschitz.weight",),
}
"""The official LipVQ-VAE's differences measured one at a time: row -> the fields it takes
from `lipvq_official()` (the values are that config's; every other field is the paper's).
The last layer alone is normalised as the official code does it: one bound per output row,
initialised to ones, randn weights, a sigmoid after it."""


def _leaf_values(config, prefix: str = "") -> dict[str, object]:
    out = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            out.update(_leaf_values(value, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = value
    return out


def config_differences(a, b) -> dict[str, tuple[object, object]]:
    """{dotted field path: (value in `a`, value in `b`)} for every leaf field where two
    configs of the same class differ (nested configs expanded)."""
    va, vb = _leaf_values(a), _leaf_values(b)
    return {path: (va[path], vb[path]) for path in va if va[path] != vb[path]}


def _take_fields(base, source, paths: Sequence[str]):
    """`base` with the fields at `paths` set to `source`'s values."""
    from icil_paper.config_data import get_path, replace_path

    for path in paths:
        base = replace_path(base, path, get_path(source, path))
    return base


def official_configs(preset: Preset) -> dict[str, tuple]:
    """Row -> (ICRT config, tokenizer config) of every `official` row. The official-code
    rows take every field in which `lipvq_official()` / `official_bin()` differ from the
    paper's defaults onto the preset's own config (so sizes stay the preset's); the
    single-difference rows take `OFFICIAL_SINGLE_DIFFERENCES`' fields only; the minibatch
    row changes ICRT's `prompt_from` only."""
    from icil_paper.tokenizers.configs import BinConfig, LipVQConfig, lipvq_official, official_bin

    icrt, lipvq, bin_ = preset.policies.icrt, preset.tokenizers.lipvq, preset.tokenizers.bin
    off_lipvq = lipvq_official(lipvq.latent_dim, lipvq.codebook_size)
    off_bin = official_bin(bin_.latent_dim)
    all_lipvq = config_differences(off_lipvq, LipVQConfig(latent_dim=lipvq.latent_dim,
                                                          codebook_size=lipvq.codebook_size))
    all_bin = config_differences(off_bin, BinConfig(latent_dim=bin_.latent_dim))
    out = {OFFICIAL_PAPER_LIPVQ: (icrt, lipvq),
           "icrt+lipvq (official code)": (icrt, _take_fields(lipvq, off_lipvq, all_lipvq))}
    for name, paths in OFFICIAL_SINGLE_DIFFERENCES.items():
        out[name] = (icrt, _take_fields(lipvq, off_lipvq, paths))
    out[OFFICIAL_PAPER_BIN] = (icrt, bin_)
    out["icrt+bin (official code)"] = (icrt, _take_fields(bin_, off_bin, all_bin))
    out["prompts from the minibatch"] = (dataclasses.replace(icrt, prompt_from="minibatch"),
                                         lipvq)
    return out


def official_seeds(preset: Preset) -> int:
    """Training seeds of every `official` row: `tables.official_seeds`, else `icrt_seeds`."""
    return preset.tables.official_seeds or preset.tables.icrt_seeds


def official(preset: Preset) -> TableSpec:
    """The paper against its official code: ICRT on the kitchen suite with the paper's
    LipVQ-VAE and Bin (Table I's policies, the same RunSpecs, with more seeds where
    `official_seeds` asks for them), the official code's LipVQ-VAE (every difference at
    once), each of three of its differences alone, the official Bin (20 running bins) and
    prompts drawn from the training minibatch; Table I's protocol and episodes, success per
    family and on average, and each trained tokenizer's latent features (codes used: the
    official design is known to collapse its codebook)."""
    tasks = preset.data.kitchen_tasks
    configs = official_configs(preset)
    paper_rows = {OFFICIAL_PAPER_LIPVQ: label("icrt", "lipvq"),
                  OFFICIAL_PAPER_BIN: label("icrt", "bin")}
    rows = []
    for name, _ in OFFICIAL_ROWS:
        policy, tok = configs[name]
        seeds = row_seeds(preset, "official", name, official_seeds(preset))
        if name in paper_rows:  # Table I's runs
            seeds = max(seeds, table_i_seeds(preset, "icrt", paper_rows[name].split("+")[1]))
        runs = [r.replace(policy=policy) for r in _runs(preset, "icrt", tok, tasks, seeds)]
        cells = _family_cells(preset, runs, tasks)
        cells["features"] = Cell(tuple(Unit(s, run, features=feature_spec(preset, run))
                                       for s, run in enumerate(runs)))
        rows.append(Row(name, cells, paper.TABLE_I_ROBOCASA[paper_rows[name]]
                        if name in paper_rows else {}))
    return TableSpec("official", "The paper against its official code (our kitchen suite, "
                                 "Table I's protocol)",
                     (*FAMILY_COLUMNS, "avg", "features"), tuple(rows), note=(
                         "ICRT with the paper's LipVQ-VAE and Bin (Table I's policies) beside "
                         "the official code's: its LipVQ-VAE with every difference (last "
                         "layer only normalised, per-row bounds, sigmoid output, GELU, no "
                         "straight-through estimator, codebook weight 0.25, no Lipschitz "
                         "term, the policy given the detached latent), three of them alone, "
                         "its Bin (20 bins over the running min and max) and its prompts "
                         "(other demonstrations of the training minibatch, any task). "
                         "`features` holds each trained tokenizer's codes used, latent scale "
                         "and least energy on held-out trajectories."))


TABLES["official"] = official


def check_row_seeds(preset: Preset) -> None:
    """Refuse, before any work, a `tables.row_seeds` entry that names no table or no row of
    its table (UnknownNameError with a "did you mean"); Fig. 5's rows are its codebook sizes,
    Table I's include the rows of the tables that share its runs (Table IV's Lip-MLP)."""
    from icil_paper.registry import check_name

    for name in preset.tables.seeds_by_row():
        table, row = name.split(":", 1)
        check_name("tables.row_seeds table", table, TABLES)
        if row == "*":
            continue
        if table == "fig5":
            rows = [str(s) for s in preset.tables.codebook_sizes]
        else:
            rows = [r.label for r in table_spec(preset, table).rows]
            if table == "I":
                rows += [r.label for r in table_spec(preset, "IV").rows]
        check_name(f"tables.row_seeds row of table {table}", row, list(dict.fromkeys(rows)))


def icrt_rows(preset: Preset, seeds: dict[str, int]) -> TableSpec:
    """Table I's protocol for chosen ICRT tokenizers at chosen training seeds (tokenizer ->
    seeds; `icil-paper compare`): each row's runs and evaluations are those Table I has for
    that tokenizer (its first seeds are the same records), so stored cells are reused, and a
    tokenizer Table I does not have (a plugin's) is trained and evaluated the same way."""
    tasks = preset.data.kitchen_tasks
    rows = tuple(Row(label("icrt", tok), _family_cells(preset, _runs(preset, "icrt", tok, tasks,
                                                                      n), tasks),
                     paper.TABLE_I_ROBOCASA.get(label("icrt", tok), {}))
                 for tok, n in seeds.items())
    return TableSpec("I", "ICRT tokenizers on Table I's protocol (our kitchen suite)",
                     (*FAMILY_COLUMNS, "avg"), rows, note=(
                         "Table I's runs and evaluations for the chosen tokenizers; avg is "
                         "the mean over tasks."))
