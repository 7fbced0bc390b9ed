"""What the chapters show of a study's records: seed averages, intervals and verdicts in words.

    from icil_paper.book.studies import tokenizer_study
    from icil_paper.book.summaries import SeedRecords
    seeds = SeedRecords(tokenizer_study(preset, store))    # {label: [metrics per seed]}
    seeds.mean("lipvq", "usage")                            # mean over training seeds
    seeds.with_interval("lipvq", "least_energy")            # "0.012 [0.01, 0.014]"
    seeds.compare("lipvq", "vq", "least_energy")            # "lipvq minus vq on ...: ... smoother"
    seeds.seed_means()                                      # one row of means per label

The records are the stand-alone studies' (`studies.tokenizer_study`, `studies.lipschitz_study`):
each label holds one metrics dict per training seed, in seed order. Chapters call these and
show the result; they define no statistics of their own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from icil_paper.metrics import ascending, rank_correlation
from icil_paper.paper.table_i import TABLE_I_ROBOCASA


class SeedRecords:
    """A study's records, {label: [metrics of each training seed]}, summarised over seeds."""

    def __init__(self, records: Mapping[str, Sequence[Mapping[str, Any]]]):
        self.records = {label: list(ms) for label, ms in records.items()}
        empty = [label for label, ms in self.records.items() if not ms]
        if empty:
            raise ValueError(f"no seed's record for {empty}: run the study first")

    @property
    def n_seeds(self) -> int:
        """Training seeds of the first label (every label of a study has the same)."""
        return len(next(iter(self.records.values()))) if self.records else 0

    def mean(self, label: str, key: str) -> float | None:
        """The mean of `key` over the seeds that recorded it (None where none did)."""
        values = [m[key] for m in self.records[label] if m.get(key) is not None]
        return float(np.mean(values)) if values else None

    def per_level(self, label: str) -> str | None:
        """Residual VQ: the codes each level uses, mean over seeds ("8 / 7"); None for a
        tokenizer with one codebook."""
        levels = [m["codes_used_per_level"] for m in self.records[label]
                  if m.get("codes_used_per_level")]
        return " / ".join(f"{v:.0f}" for v in np.mean(levels, axis=0)) if levels else None

    def scores(self, label: str, key: str) -> np.ndarray:
        """(seeds, trajectories) per-trajectory scores of `key` (`<key>_per_trajectory`)."""
        return np.array([m[f"{key}_per_trajectory"] for m in self.records[label]], dtype=float)

    def with_interval(self, label: str, key: str, digits: int = 3) -> str:
        """The mean score with its 95% interval (`stats.score_mean`), as text."""
        from icil_paper import stats

        est = stats.score_mean(self.scores(label, key))
        return f"{est.value:.{digits}g} [{est.low:.{digits}g}, {est.high:.{digits}g}]"

    def compare(self, a: str, b: str, key: str) -> str:
        """Is `a` smoother than `b` on `key`? The paired difference and its verdict in words
        (`tables.display.smoother_sentence`: lower is smoother)."""
        from icil_paper.tables.display import smoother_sentence

        return smoother_sentence(a, b, self.scores(a, key), self.scores(b, key),
                                 key.replace("_", " "))

    def seed_means(self) -> dict[str, dict[str, Any]]:
        """One row per label: the mean over seeds of every number, seed 0's value of
        everything else (curves, lists, names)."""
        rows = {}
        for label, ms in self.records.items():
            first = ms[0]
            rows[label] = {k: (float(np.mean([m[k] for m in ms]))
                               if isinstance(v, (int, float))
                               else v) for k, v in first.items()}
        return rows


# --------------------------------------------------------------------------- chapter 03
BOUND_RTOL = 1e-5
"""The relative slack of chapter 03's bound check: an empirical constant may exceed the
product of the layers' norms by float32 rounding, no more."""


def bound_holds(metrics: Sequence[Mapping[str, Any]], radii: Sequence[float],
                rtol: float = BOUND_RTOL) -> bool:
    """Whether every seed's empirical inf-norm Lipschitz constant (the largest over `radii`)
    stays within its bound prod ||W_l||_inf (Eq. 4's guarantee), up to `rtol`."""
    return all(max(m[f"empirical_inf_r{r:g}"] for r in radii) <= m["bound_inf"] * (1 + rtol)
               for m in metrics)


def lipschitz_findings(by_seed: Mapping[str, Sequence[Mapping[str, Any]]],
                       radii: Sequence[float], lr: float) -> str:
    """Chapter 03's "What we found", from the Lipschitz study's records (`by_seed`, label ->
    metrics per training seed; `lr` the study's learning rate): the bound check of every
    encoder, how LipVQ-VAE's per-layer bounds moved in training and why, spectral
    normalization's bounds against LipVQ-VAE's, and each encoder's reconstruction error."""
    seeds = SeedRecords(by_seed)
    records = seeds.seed_means()
    holds = {label: bound_holds(ms, radii) for label, ms in by_seed.items()}
    paper = records["lipvq (paper)"]
    c_hist = np.array(paper["c_history"])  # (logged steps, layers)
    start, end = c_hist[0], c_hist[-1]
    steps = paper["history_step"][-1]
    drift = float(np.mean(end - start)) / steps
    change = ", ".join(f"layer {i + 1}: {a:.3g} -> {b:.3g} ({(b - a) / a:+.1%})"
                       for i, (a, b) in enumerate(zip(start, end, strict=True)))
    lip, spec, plain = (records["lipvq (paper)"], records["vq + spectral norm"],
                        records["vq (no normalization)"])
    emp = {label: max(m[f"empirical_inf_r{r:g}"] for r in radii) for label, m in records.items()}
    lines = [
        f"Bound check (inf-norm, every model and each of its {seeds.n_seeds} seed(s)): "
        + "; ".join(f"{k}: {'held' if v else 'VIOLATED'}" for k, v in holds.items()) + ".",
        f"LipVQ-VAE's per-layer bounds softplus(c_l) over {steps} steps: {change}. "
        f"Their product ends at {paper['bound_softplus_product']:.4g}; the empirical constant "
        f"is {emp['lipvq (paper)']:.4g}, "
        f"{emp['lipvq (paper)'] / paper['bound_softplus_product']:.2%} of it.",
        "With Liu et al.'s initialisation (c_l = the largest initial row sum) nothing is "
        "rescaled at the start. The 1e-6 weight does not make the bounds' steps small: Adam "
        "scales every parameter's step to about the learning rate, so softplus(c_l) drifts "
        f"{'down' if drift < 0 else 'up'} by {abs(drift):.2g} per step on average (learning "
        f"rate {lr:g}), {np.max(np.abs(end - start) / start):.2%} of its value at most in "
        "this run. The constraint bites only once a row's sum reaches its shrinking bound.",
        f"Spectral normalization gives a 2-norm bound of {spec['bound_2']:.3g} (about 1 per "
        f"layer) and an inf-norm bound of {spec['bound_inf']:.3g}; its empirical inf-norm "
        f"constant is {emp['vq + spectral norm']:.3g} against {emp['lipvq (paper)']:.3g} for "
        f"LipVQ-VAE and {emp['vq (no normalization)']:.3g} without normalization.",
        f"Reconstruction MSE: LipVQ-VAE {lip['reconstruction_mse']:.4g}, spectral "
        f"{spec['reconstruction_mse']:.4g}, unnormalized {plain['reconstruction_mse']:.4g}, "
        f"official-code variant {records['lipvq (official code)']['reconstruction_mse']:.4g}.",
    ]
    return "\n\n".join(lines)


# --------------------------------------------------------------------------- chapter 05
TOKENIZER_SCORES = ("least_energy", "least_energy_standardized")
"""The latent smoothness scores chapter 05 ranks the tokenizers by (lower is smoother)."""

LOW_USAGE = 0.1
"""A codebook that uses under this share of its codes on held-out data has collapsed."""


def tokenizer_findings(seeds: SeedRecords, paper_smoothness: Mapping[str, float],
                       tokenizers: Sequence[str], keys: Sequence[str] = TOKENIZER_SCORES) -> str:
    """Chapter 05's "What we found", from the tokenizer study's records (`seeds`): our
    smoothness rankings against the paper's (`paper_smoothness`, tokenizer -> its Table III
    least energy; `tokenizers` the registry's names, in order), the paired smoothness
    comparisons of each Lipschitz variant with its base, the latent scale, codebook
    collapse, the official code's variant, throughput and codes used per level."""
    records = seeds.records
    paper_names = [k for k in tokenizers if k in paper_smoothness]
    lines = [f"Paper's smoothness ranking (smoothest first): "
             f"{', '.join(ascending(paper_smoothness))}."]
    for key in keys:
        ours = {k: float(seeds.scores(k, key).mean()) for k in paper_names}
        lines.append(f"Our {key.replace('_', ' ')} ranking: {', '.join(ascending(ours))}; rank "
                     f"correlation with the paper's "
                     f"{rank_correlation(ours, paper_smoothness):+.2f}.")
    for key in keys:
        lines.append("LipVQ-VAE against VQ-VAE (the Lipschitz constraint alone): "
                     + seeds.compare("lipvq", "vq", key) + ".")
        lines.append("With codebooks initialised from encoder outputs: "
                     + seeds.compare("lipvq-data-init", "vq-data-init", key) + ".")
        lines.append("Eq. 4 on FSQ's encoder: " + seeds.compare("lipfsq", "fsq", key) + ".")
        lines.append("Eq. 4 on residual VQ's encoder: " + seeds.compare("liprvq", "rvq", key)
                     + ".")
    lines.append(f"Latent scale σ: LipVQ-VAE {seeds.mean('lipvq', 'latent_scale'):.3g}, VQ-VAE "
                 f"{seeds.mean('vq', 'latent_scale'):.3g}; the raw least energy scales with σ².")
    low_usage = [k for k in records
                 if seeds.mean(k, "usage") is not None and seeds.mean(k, "usage") < LOW_USAGE]
    if low_usage:
        lines.append(f"Codebook collapse (under {LOW_USAGE:.0%} of codes used on held-out data, "
                     "mean over seeds): "
                     + ", ".join(f"{k} ({seeds.mean(k, 'codes_used'):.0f} of "
                                 f"{seeds.mean(k, 'codebook_size'):.0f})" for k in low_usage)
                     + ".")
    lines.append(
        f"The official code's LipVQ variant (sigmoid output, no straight-through) uses "
        f"{seeds.mean('lipvq-official', 'codes_used'):.0f} code(s) and reconstructs with MSE "
        f"{seeds.mean('lipvq-official', 'reconstruction_mse'):.4g}, against "
        f"{seeds.mean('lipvq', 'codes_used'):.0f} codes and "
        f"{seeds.mean('lipvq', 'reconstruction_mse'):.4g} for the paper's.")
    rates = {k: seeds.mean(k, "encode_decode_actions_per_s") for k in records}
    fastest, slowest = max(rates, key=rates.get), min(rates, key=rates.get)
    lines.append(
        f"Throughput (encode + decode, one core): from {rates[slowest]:,.0f} actions/s "
        f"({slowest}) to {rates[fastest]:,.0f} ({fastest}). FAST emits "
        f"{seeds.mean('fast', 'tokens_per_step'):.2f} tokens per step, bin "
        f"{seeds.mean('bin', 'tokens_per_step'):.0f}, B-spline "
        f"{seeds.mean('bspline', 'tokens_per_step'):.2f}, the others one embedding per step.")
    levels = len(records["rvq"][0]["codes_used_per_level"])
    lines.append(
        f"Residual VQ uses {seeds.per_level('rvq')} codes per level (of "
        f"{seeds.mean('rvq', 'codebook_size') / levels:.0f} each), "
        f"{seeds.per_level('liprvq')} with Eq. 4; FSQ {seeds.mean('fsq', 'codes_used'):.0f} of "
        f"its {seeds.mean('fsq', 'codebook_size'):.0f} grid points, "
        f"{seeds.mean('lipfsq', 'codes_used'):.0f} with Eq. 4.")
    return "\n\n".join(lines)


# --------------------------------------------------------------------------- chapter 04
EXPERT_REQUIREMENT = 0.9
"""The success an expert must reach over random scenes (the paper's data need it)."""


def demonstration_findings(showcase: Mapping[str, Mapping[str, Any]], kept, experts, summary,
                           tasks: Sequence[str], preset_name: str) -> str:
    """Chapter 04's "What we found": whether each shown task's demo 0 succeeded
    (`showcase`), the experts' success over the scenes the data sets were generated on
    (`kept`, a frame with a "generated: success over data-set scenes" column) and over fresh
    scenes with replay (`experts`, `studies.expert_measurements` as a frame), and, for each of
    `tasks`, how the human source's demos differ from the generated ones (`summary`, by
    (task, source): mean length, still fraction, least energy per step)."""
    lines = []
    failed_shown = [t for t, e in showcase.items() if not e["success"]]
    lines.append(f"Demo 0 of the generated source succeeded on "
                 f"{len(showcase) - len(failed_shown)} of {len(showcase)} shown tasks"
                 + (f" (failed: {failed_shown})." if failed_shown else "."))
    generated_rate = kept["generated: success over data-set scenes"]
    low_kept = generated_rate[generated_rate < EXPERT_REQUIREMENT]
    lines.append(f"Over the scenes the {preset_name} data sets were generated on, the experts "
                 f"succeeded in {generated_rate.min():.0%}-{generated_rate.max():.0%} of "
                 "attempts per task; " + ("every task meets 0.9 there." if low_kept.empty else
                                          f"below 0.9: {list(low_kept.index)}."))
    if len(experts):
        low = experts[experts.expert < EXPERT_REQUIREMENT]
        lines.append(f"Over {int(experts.seeds.min())}+ random scenes per task, the expert "
                     f"success rate ranges from {experts.expert.min():.2f} to "
                     f"{experts.expert.max():.2f}; "
                     + ("every measured expert meets the 0.9 requirement."
                        if low.empty else f"below 0.9: {list(low.task)}."))
        if experts.replay.notna().all():
            lines.append(f"Replaying the stored actions of successful episodes open loop "
                         f"succeeds again in {experts.replay.min():.0%}-"
                         f"{experts.replay.max():.0%} of them.")
    for task in tasks:
        g, h = summary.loc[(task, "generated")], summary.loc[(task, "human")]
        energy = h.least_energy_per_step / max(g.least_energy_per_step, 1e-12)
        lines.append(
            f"{task}: human demos are {h.mean_length / g.mean_length:.2f}x as long as generated "
            f"ones ({h.mean_length:.0f} vs {g.mean_length:.0f} steps), stand still in "
            f"{h.still_fraction:.0%} vs {g.still_fraction:.0%} of steps, and their least energy "
            f"per step is {energy:.3g}x the generated demos' "
            + ("(less smooth, as the human source is meant to be)." if energy > 1 else
               "(NOT less smooth: the human source does not differ as intended here)."))
    return "\n".join(lines)


# --------------------------------------------------------------------------- chapter 02
def icrt_findings(metrics: Mapping[str, Any], query_tokens: int, prompt_tokens: int,
                  task: str, preset_name: str) -> str:
    """Chapter 02's "What we found", as a Markdown list: the tokens the loss reached on a
    real batch (`query_tokens` supervised query tokens, `prompt_tokens` prompt tokens: 0 as
    Sec. III-A says), how far training lowered the loss, and the rollouts' success on
    `task` with its interval beside the paper's drawer family (Table I), from the ICRT
    study's `metrics` (its train and eval records merged, the train record under "train")."""
    m = metrics
    paper = TABLE_I_ROBOCASA["icrt+lipvq"]["drawers"]
    loss_drop = m["loss"][0] / max(m["loss"][-1], 1e-12)
    held = "within" if m["ci_low"] <= paper <= m["ci_high"] else "outside"
    return (
        f"- The token layout, mask and loss coverage above are computed from a real batch: the "
        f"loss reached {query_tokens} supervised query tokens and {prompt_tokens} prompt "
        f"tokens, as Sec. III-A describes (no loss on the prompt).\n"
        f"- Training ({m['train']['steps']} steps, preset '{preset_name}') lowered the total "
        f"loss {loss_drop:.1f}-fold.\n"
        f"- On {task}, ICRT + LipVQ-VAE succeeded in {m['successes']} of {m['episodes']} "
        f"rollouts ({m['success_rate']:.2f}, 95% CI {m['ci_low']:.2f}-{m['ci_high']:.2f}). The "
        f"paper reports {paper:.2f} on RoboCasa's drawer family after 500K iterations on "
        f"MimicGen data; its number lies {held} our interval of {m['episodes']} episode(s). "
        "Our task, data and training budget are stand-ins at a much smaller scale, so this "
        "chapter checks the mechanics, not the paper's number.")
