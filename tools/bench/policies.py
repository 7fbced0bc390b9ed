"""Policy benchmark: ICRT's per-step inference latency with and without the KV cache, and
training steps per second, at the small, reference and full presets' sizes.

    python -m tools.bench.policies            # CPU (and the GPU too, when one is present)
    python -m tools.bench.policies --quick    # fewer repetitions

Latency: ICRT (LipVQ-VAE tokenizer) is given a prompt of 100, 400 or 1600 tokens and then
acts for a few query steps. With the cache a step is `select_action(obs)` (two new tokens
attend to the cached keys and values); without it every step recomputes the whole sequence
with `predict`. The prefill (`reset(prompt)`) is timed apart; reported: median ms per step.

Training: steps per second of the training loop's inner step (batch sampling, forward,
backward, clipping, AdamW) at each preset's policy and batch size, on prompts of 100-step
synthetic demonstrations (`sim.synthetic`) with 32-step queries; on a GPU under bf16
autocast, with the peak memory. CPU figures use one torch thread (`--threads`), as CPU
training does. Weights are untrained (timing does not depend on them). Writes
results/bench/policies.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from typing import Any

import numpy as np
import torch

from icil_paper.config import get_preset
from icil_paper.policies import make_policy
from icil_paper.policies.batching import batch_to
from icil_paper.results import save_benchmark
from icil_paper.seeding import seed_everything
from icil_paper.sim.synthetic import synthetic_demos
from icil_paper.train.optim import make_optimizer

PROMPT_TOKENS = (100, 400, 1600)
SIZES = ("small", "full")
"""Model sizes timed for inference latency (`reference` uses `small`'s model)."""
TRAINING_SIZES = ("small", "reference", "full")


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize()


def build_icrt(size: str, device: torch.device, max_seq_len: int = 4096):
    """ICRT + LipVQ-VAE at the policy size of preset `size`, untrained, in eval mode."""
    preset = get_preset(size)
    config = dataclasses.replace(preset.policies.icrt, max_seq_len=max_seq_len, dropout=0.0)
    policy = make_policy(config, {"proprio": 9, "object": 6}, 7, preset.tokenizers.lipvq)
    policy.prepare(synthetic_demos(1, 2, steps=20))
    return policy.to(device).eval(), preset


def latency(size: str, prompt_tokens: int, device: torch.device, steps: int) -> dict[str, Any]:
    """Median ms per query step with and without the KV cache, and the prefill time."""
    policy, _ = build_icrt(size, device)
    prompt = synthetic_demos(1, 1, steps=prompt_tokens // 2, seed=1)[0]
    query = synthetic_demos(1, 1, steps=steps + 1, seed=2)[0]
    obs_at = [{k: v[t] for k, v in query.obs.items()} for t in range(steps + 1)]

    with torch.no_grad():
        _sync(device)
        t0 = time.perf_counter()
        policy.reset(prompt)
        _sync(device)
        prefill_ms = 1e3 * (time.perf_counter() - t0)
        policy.select_action(obs_at[0])  # warm-up
        cached, actions = [], [np.zeros(7, np.float32)]
        for t in range(1, steps + 1):
            _sync(device)
            t0 = time.perf_counter()
            actions.append(policy.select_action(obs_at[t]))
            _sync(device)
            cached.append(1e3 * (time.perf_counter() - t0))

        def batch_until(t: int) -> dict[str, Any]:
            dev = policy.device
            return {
                "prompt_obs": {k: torch.from_numpy(v)[None].to(dev) for k, v in prompt.obs.items()},
                "prompt_actions": torch.from_numpy(prompt.actions)[None].to(dev),
                "prompt_valid": torch.ones(1, len(prompt.actions), dtype=torch.bool, device=dev),
                "query_obs": {k: torch.from_numpy(v[:t + 1])[None].to(dev)
                              for k, v in query.obs.items()},
                "query_actions": torch.from_numpy(np.stack(actions[:t + 1]))[None].to(dev),
                "query_valid": torch.ones(1, t + 1, dtype=torch.bool, device=dev),
                "instruction": [""],
            }

        policy.predict(batch_until(0))  # warm-up
        full = []
        for t in range(1, steps + 1):
            b = batch_until(t)
            _sync(device)
            t0 = time.perf_counter()
            policy.predict(b)
            _sync(device)
            full.append(1e3 * (time.perf_counter() - t0))
    return {"size": size, "prompt_tokens": prompt_tokens, "device": str(device),
            "query_steps": steps, "prefill_ms": round(prefill_ms, 3),
            "step_ms_kv_cache": round(statistics.median(cached), 3),
            "step_ms_recompute": round(statistics.median(full), 3),
            "speedup": round(statistics.median(full) / statistics.median(cached), 2)}


def training_speed(size: str, device: torch.device, steps: int) -> dict[str, Any]:
    """Optimizer steps per second of ICRT + LipVQ-VAE at the size and batch of preset `size`."""
    policy, preset = build_icrt(size, device)
    demos = synthetic_demos(2, 4, steps=100, seed=3)
    data = policy.prepare(demos)
    policy.to(device).train()
    tc = preset.train
    opt = make_optimizer(policy, tc.lr, tc.weight_decay, tc.betas)
    rng = np.random.default_rng(0)

    bf16 = device.type == "cuda"

    def one_step() -> None:
        batch = batch_to(policy.sample_batch(data, tc.batch_size, rng), device)
        with torch.autocast(device.type, dtype=torch.bfloat16, enabled=bf16):
            loss, _ = policy(batch)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(policy.parameters(), tc.grad_clip)
        opt.step()

    one_step()  # warm-up
    _sync(device)
    if device.type == "cuda":
        torch.cuda.reset_peak_memory_stats(device)
    t0 = time.perf_counter()
    for _ in range(steps):
        one_step()
    _sync(device)
    wall = time.perf_counter() - t0
    return {"size": size, "device": str(device), "batch_size": tc.batch_size,
            "query_len": preset.policies.icrt.query_len, "prompt_steps": 100, "steps": steps,
            "d_model": preset.policies.icrt.d_model, "n_layer": preset.policies.icrt.n_layer,
            "n_params": sum(p.numel() for p in policy.parameters()),
            "steps_per_s": round(steps / wall, 3), "s_per_step": round(wall / steps, 4),
            "precision": "bf16 autocast" if bf16 else "fp32",
            "peak_memory_mib": (round(torch.cuda.max_memory_allocated(device) / 2**20, 1)
                                if device.type == "cuda" else None)}


def run(quick: bool = False, seed: int = 0, devices: list[str] | None = None,
        progress: bool = True) -> dict[str, Any]:
    """Measure everything on each device; returns the JSON-ready result."""
    seed_everything(seed)
    if devices is None:
        devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    lat_steps = 5 if quick else 20
    rows_lat, rows_train = [], []
    for dev_name in devices:
        device = torch.device(dev_name)
        for size in SIZES:
            for n in PROMPT_TOKENS:
                row = latency(size, n, device, lat_steps)
                rows_lat.append(row)
                if progress:
                    print(f"  latency {dev_name} {size:5s} prompt {n:5d} tokens: "
                          f"{row['step_ms_kv_cache']:8.2f} ms/step cached, "
                          f"{row['step_ms_recompute']:8.2f} ms/step recomputed, "
                          f"prefill {row['prefill_ms']:8.1f} ms", flush=True)
        for size in TRAINING_SIZES:
            n_steps = {"small": 5 if quick else 20, "reference": 5 if quick else 20,
                       "full": 2 if quick else 3}[size]
            if device.type == "cuda":
                n_steps *= 10
            row = training_speed(size, device, n_steps)
            rows_train.append(row)
            if progress:
                print(f"  training {dev_name} {size:9s}: {row['steps_per_s']:.3f} steps/s "
                      f"(batch {row['batch_size']}, {row['n_params']:,} parameters)", flush=True)
    return {"quick": quick, "seed": seed, "threads": torch.get_num_threads(),
            "latency": rows_lat, "training": rows_train}


def format_table(result: dict[str, Any]) -> str:
    """The result as plain-text tables."""
    lines = [f"ICRT + LipVQ-VAE per-step latency, median ms ({result['threads']} threads)",
             f"{'device':6s} {'size':5s} {'prompt':>7s} {'KV cache':>10s} {'recompute':>10s} "
             f"{'speedup':>8s} {'prefill':>9s}"]
    for r in result["latency"]:
        lines.append(f"{r['device']:6s} {r['size']:5s} {r['prompt_tokens']:>7d} "
                     f"{r['step_ms_kv_cache']:>10.2f} {r['step_ms_recompute']:>10.2f} "
                     f"{r['speedup']:>7.1f}x {r['prefill_ms']:>9.1f}")
    lines.append("Training steps per second")
    for r in result["training"]:
        memory = f", peak {r['peak_memory_mib']} MiB" if r.get("peak_memory_mib") else ""
        lines.append(f"{r['device']:6s} {r['size']:9s} batch {r['batch_size']:>3d}  "
                     f"{r['steps_per_s']:>8.3f} steps/s  ({r['n_params']:,} parameters, "
                     f"{r.get('precision', 'fp32')}{memory})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.bench.policies",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", action="append", default=None,
                        help="cpu and/or cuda (default: cpu, plus cuda when present)")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads (default 1, as training on CPU uses; "
                             "0: torch's own choice)")
    parser.add_argument("--out", default=None,
                        help="output JSON (default: results/bench/policies.json)")
    args = parser.parse_args(argv)
    if args.threads:
        torch.set_num_threads(args.threads)
    result = run(quick=args.quick, seed=args.seed, devices=args.device)
    print(format_table(result))
    save_benchmark("policies", result, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
