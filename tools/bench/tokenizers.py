"""Tokenizer benchmark: encode + decode throughput on CPU, and FAST's BPE fitting time.

    python -m tools.bench.tokenizers            # paper sizes, BPE fitted on 1M actions
    python -m tools.bench.tokenizers --quick    # 100k actions, shorter timings

Every tokenizer is built at the paper's sizes (the configs' defaults) and timed on a batch
of (B, T) action windows from generated trajectories (`icil_paper.data.trajectories`), with
one torch thread and with all threads. Encode is a full `forward` (embeddings, codes,
reconstruction and losses); decode is `decode(embeddings)`. Weights are untrained:
throughput does not depend on them. Writes results/bench/tokenizers.json.
"""

from __future__ import annotations

import argparse
import time

import torch

from icil_paper.config_data import to_dict
from icil_paper.data.trajectories import ACTION_DIM, generate_actions, generate_trajectories
from icil_paper.results import save_benchmark
from icil_paper.seeding import seed_everything
from icil_paper.tokenizers import TOKENIZERS, make_tokenizer
from icil_paper.tokenizers.configs import TokenizerStudyConfig, default_config, lipvq_official
from icil_paper.tokenizers.training import sample_windows, throughput

VARIANTS = [(name, default_config(name)) for name in TOKENIZERS] + [
    ("lipvq-official", lipvq_official())]
"""(label, config) at the paper's sizes (D = 64, K = 1024)."""


def run(quick: bool = False, seed: int = 0, progress: bool = True) -> dict:
    """Measure everything; returns the JSON-ready result."""
    config = TokenizerStudyConfig()
    rng = seed_everything(seed)
    fit_actions = 100_000 if quick else config.bench_fast_actions
    batch_shape = (64, 16)
    min_time = 0.3 if quick else 1.0
    trajectories = generate_trajectories(200, seed=seed, noise=config.trajectory_noise)
    batch = torch.from_numpy(sample_windows(trajectories, *batch_shape, rng))

    rows = []
    for label, tok_config in VARIANTS:
        tok = make_tokenizer(tok_config, ACTION_DIM).fit(trajectories)
        row = {"tokenizer": label}
        for threads in (1, torch.get_num_threads()):
            rates = throughput(tok, batch, min_time=min_time, threads=threads)
            row.update({f"{key}@{threads}t": value for key, value in rates.items()})
        rows.append(row)
        if progress:
            print(f"  {label:15s} encode+decode {row['encode_decode_actions_per_s@1t']:>12,.0f} "
                  "actions/s (1 thread)", flush=True)

    start = time.perf_counter()
    fit_set = generate_actions(fit_actions, seed=seed + 1, noise=config.trajectory_noise)
    generate_s = time.perf_counter() - start
    fast = make_tokenizer("fast", ACTION_DIM)
    start = time.perf_counter()
    fast.fit(fit_set)
    fit_s = time.perf_counter() - start
    n_actions = sum(len(t) for t in fit_set)
    fast_fit = {"actions": n_actions, "trajectories": len(fit_set), "fit_s": fit_s,
                "generate_s": generate_s, "vocab_size": fast.bpe_vocab_size,
                "base_symbols": fast.max_token - fast.min_token + 1,
                "tokens_per_step": fast.tokens_per_step(fit_set[:500])}
    return {
        "benchmark": "tokenizers",
        "quick": quick,
        "seed": seed,
        "batch_shape": list(batch_shape),
        "threads_available": torch.get_num_threads(),
        "config": to_dict(config),
        "throughput": rows,
        "fast_bpe_fit": fast_fit,
    }


def format_table(result: dict) -> str:
    """The result as a plain-text table."""
    threads = result["threads_available"]
    lines = [f"Tokenizer throughput on CPU, actions/s (batch {tuple(result['batch_shape'])}; "
             f"1 thread / {threads} threads)",
             f"{'tokenizer':15s} {'encode':>21s} {'decode':>21s} {'encode+decode':>21s}"]
    for row in result["throughput"]:
        cells = []
        for key in ("encode_actions_per_s", "decode_actions_per_s", "encode_decode_actions_per_s"):
            cells.append(f"{row[f'{key}@1t']:>10,.0f}/{row[f'{key}@{threads}t']:<10,.0f}")
        lines.append(f"{row['tokenizer']:15s} " + " ".join(cells))
    fit = result["fast_bpe_fit"]
    lines.append(f"FAST BPE fit on {fit['actions']:,} actions: {fit['fit_s']:.1f} s "
                 f"(vocabulary {fit['vocab_size']}, {fit['base_symbols']} base symbols, "
                 f"{fit['tokens_per_step']:.3f} tokens per step)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.tokenizers",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="fit FAST on 100k actions and time for less long")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None,
                        help="output JSON (default: results/bench/tokenizers.json)")
    args = parser.parse_args(argv)
    result = run(quick=args.quick, seed=args.seed)
    print(format_table(result))
    save_benchmark("tokenizers", result, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
