"""The one training loop for every policy, and `icil-paper train`.

    from icil_paper.train import train_policy
    result = train_policy("small", policy="icrt", tokenizer="lipvq",
                          tasks=["kitchen/open_drawer"], source="generated")
    result.policy.reset(prompt=demo); result.policy.select_action(obs)

What one run does, in order:

1. `seed_everything(seed)`; load the demonstrations (`icil_paper.data`), or take the ones
   passed as `demos=` (tests, notebooks).
2. Build the policy (`make_policy`) and `prepare` it: observation normalization fitted on
   the training demonstrations, `tokenizer.fit` on the training actions for tokenizers that
   need it (bin ranges, FAST's BPE), MCR's encoder pre-training.
3. AdamW (decoupled weight decay on matrices only, as nanoGPT), linear warm-up then a
   half-cycle cosine to zero, gradient-norm clipping, optional EMA of the weights.
4. Every `ckpt_every` steps and at the end, a checkpoint is written atomically to
   `<run_dir>/checkpoint.pt`: model, optimizer, scheduler, EMA, the NumPy / torch / Python
   RNG states and the step. With `resume=True` a run continues from it; on CPU the result
   is bit for bit the one of an uninterrupted run (a test checks it). Metrics go to
   `<run_dir>/metrics.jsonl` (one JSON line every `log_every` steps; lines past the
   checkpoint are dropped on resume), the run's arguments to `<run_dir>/config.json`, and
   the trained policy (EMA weights if EMA is on) to `<run_dir>/policy.pt`.

Run folders live under `runs/<preset>/` in the repository (or $ICIL_RUNS).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import inspect
import io
import json
import math
import os
import random
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from icil_paper.config import PRESET_NAMES, Preset, TokenizerConfig, active_preset_name, get_preset
from icil_paper.results import atomic_write_bytes, atomic_write_json

RUNS_ENV_VAR = "ICIL_RUNS"
CHECKPOINT = "checkpoint.pt"
POLICY_FILE = "policy.pt"
METRICS_FILE = "metrics.jsonl"
CONFIG_FILE = "config.json"


# --------------------------------------------------------------------------- helpers
def runs_root() -> Path:
    """Root of run folders: $ICIL_RUNS, else `runs/` in the repository."""
    from icil_paper.provenance import REPO_ROOT

    return Path(os.environ.get(RUNS_ENV_VAR, REPO_ROOT / "runs"))


def suite_of(tasks: Sequence[str]) -> str:
    """`kitchen`, `maniskill`, or `mixed` for a list of task names."""
    suites = {t.split("/", 1)[0] for t in tasks}
    return suites.pop() if len(suites) == 1 else "mixed"


def default_run_dir(preset: Preset, policy: str, tokenizer: str | None, tasks: Sequence[str],
                    source: str) -> Path:
    """`runs/<preset>/<label>__<tasks>__<source>__seed<seed>__<hash>`.

    The hash covers every preset section a training run depends on (data, tokenizer, policy,
    train; not eval), so a changed preset trains into a new folder instead of refusing to
    resume, or overwriting, the run trained under the old one.
    """
    from icil_paper.policies import policy_label
    from icil_paper.results import config_hash

    tag = suite_of(tasks) if len(tasks) != 1 else tasks[0].replace("/", "-")
    sections = preset.to_dict()
    key = config_hash({k: sections[k] for k in ("data", "tokenizer", "policy", "train", "seed")})
    return (runs_root() / preset.name
            / f"{policy_label(policy, tokenizer)}__{tag}__{source}__seed{preset.seed}__{key[:8]}")


def tokenizer_options(name: str, cfg: TokenizerConfig) -> dict[str, Any]:
    """Constructor options of tokenizer `name` taken from the preset's TokenizerConfig.

    Only options the tokenizer's constructor accepts are passed: codebook_size (vq, lipvq,
    lfq), n_bins (bin), and FAST's scale, vocab_size and chunk.
    """
    from icil_paper.tokenizers import REGISTRY

    wanted = {"codebook_size": cfg.codebook_size, "n_bins": cfg.n_bins,
              "scale": cfg.fast_scale, "vocab_size": cfg.fast_vocab_size, "chunk": cfg.fast_chunk}
    params: dict[str, inspect.Parameter] = {}
    for cls in REGISTRY[name].__mro__:  # a subclass passing **options on: read its parents too
        if "__init__" not in vars(cls):
            continue
        own = inspect.signature(cls.__init__).parameters
        params.update(own)
        if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in own.values()):
            break
    return {k: v for k, v in wanted.items() if k in params}


def load_training_demos(preset: Preset, tasks: Sequence[str], source: str,
                        progress: bool = True, obs: str | None = None) -> list[Any]:
    """Demonstrations of every task (generated on first use; see icil_paper.data)."""
    from icil_paper.data import ensure_many, load_demos

    paths = ensure_many(preset, tasks, [source], progress=progress, obs=obs)  # one worker pool
    demos = [demo for task in tasks for demo in load_demos(paths[task, source])]
    if not demos:
        raise ValueError(f"no demonstrations for tasks {list(tasks)} from source {source!r}")
    return demos


@contextlib.contextmanager
def cpu_threads(n: int):
    """Run a block with `n` torch CPU threads (n <= 0: leave torch's setting alone)."""
    before = torch.get_num_threads()
    if n > 0:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def cosine_schedule(warmup: int, total: int):
    """lr multiplier: linear warm-up over `warmup` steps, then half-cycle cosine to 0."""
    def factor(step: int) -> float:
        if step < warmup:
            return (step + 1) / max(1, warmup)
        progress = (step - warmup) / max(1, total - warmup)
        return 0.5 * (1.0 + math.cos(math.pi * min(1.0, progress)))
    return factor


def make_optimizer(model: nn.Module, lr: float, weight_decay: float,
                   betas: tuple[float, float]) -> torch.optim.AdamW:
    """AdamW with weight decay on matrices (ndim >= 2) only, over trainable parameters."""
    params = [p for p in model.parameters() if p.requires_grad]
    decay = [p for p in params if p.ndim >= 2]
    no_decay = [p for p in params if p.ndim < 2]
    return torch.optim.AdamW([{"params": decay, "weight_decay": weight_decay},
                              {"params": no_decay, "weight_decay": 0.0}],
                             lr=lr, betas=tuple(betas))


class EMA:
    """Exponential moving average of a model's floating-point parameters and buffers.

    decay_t = min(decay, (1 + t) / (10 + t)): averaging starts short and grows to `decay`.
    """

    def __init__(self, model: nn.Module, decay: float):
        self.decay = decay
        self.step = 0
        self.shadow = {k: v.detach().clone() for k, v in model.state_dict().items()
                       if isinstance(v, torch.Tensor) and v.is_floating_point()}

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        d = min(self.decay, (1 + self.step) / (10 + self.step))
        for k, v in model.state_dict().items():
            if k in self.shadow:
                self.shadow[k].mul_(d).add_(v.detach(), alpha=1 - d)
        self.step += 1

    def copy_to(self, model: nn.Module) -> None:
        model.load_state_dict({**model.state_dict(), **self.shadow})

    def state_dict(self) -> dict[str, Any]:
        return {"decay": self.decay, "step": self.step, "shadow": self.shadow}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        self.decay, self.step = state["decay"], state["step"]
        self.shadow = {k: v.clone() for k, v in state["shadow"].items()}


def _rng_state(rng: np.random.Generator) -> dict[str, Any]:
    state = {"numpy": rng.bit_generator.state, "torch": torch.get_rng_state(),
             "python": random.getstate(), "numpy_global": np.random.get_state()}
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def _set_rng_state(rng: np.random.Generator, state: Mapping[str, Any]) -> None:
    rng.bit_generator.state = state["numpy"]
    torch.set_rng_state(state["torch"])
    random.setstate(state["python"])
    np.random.set_state(state["numpy_global"])
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


def save_torch(path: Path, obj: Any) -> None:
    """torch.save through bytes and an atomic rename (a crash never leaves half a file)."""
    buf = io.BytesIO()
    torch.save(obj, buf)
    atomic_write_bytes(Path(path), buf.getvalue())


def load_policy(path: str | Path, map_location: str | torch.device = "cpu"):
    """The trained policy saved by `train_policy` (`<run_dir>/policy.pt`)."""
    from icil_paper.policies.base import build_policy

    path = Path(path)
    if path.is_dir():
        path = path / POLICY_FILE
    if not path.exists():
        raise FileNotFoundError(f"no trained policy at {path} (train it first: icil-paper train)")
    blob = torch.load(path, map_location=map_location, weights_only=False)
    policy = build_policy(blob["spec"])
    policy.load_state_dict(blob["state_dict"])
    policy.eval()
    return policy


def policy_digest(policy: nn.Module) -> str:
    """A short hash of a policy's weights (identifies a trained policy in result configs)."""
    import hashlib

    h = hashlib.sha256()
    for k, v in sorted(policy.state_dict().items()):
        h.update(k.encode())
        if isinstance(v, torch.Tensor):
            h.update(v.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()[:16]


# --------------------------------------------------------------------------- the loop
@dataclass
class TrainResult:
    """What `train_policy` returns."""

    policy: Any
    """The trained policy (EMA weights when EMA is on), in eval mode."""
    run_dir: Path | None
    """Where checkpoints, metrics and the policy were written (None: nothing written)."""
    metrics: dict[str, Any] = field(default_factory=dict)
    """Final loss, steps, wall time, steps per second, parameter count."""
    history: list[dict[str, Any]] = field(default_factory=list)
    """The metric lines of this call (not of earlier, resumed-from calls)."""


def train_policy(preset: Preset | str | None = None, policy: str = "icrt",
                 tokenizer: str | None = None, tasks: Sequence[str] | None = None,
                 source: str = "generated", run_dir: str | Path | None = "auto",
                 resume: bool = True, demos: Sequence[Any] | None = None,
                 steps: int | None = None, seed: int | None = None, device: str | None = None,
                 progress: bool = True, policy_options: Mapping[str, Any] | None = None,
                 stop_after: int | None = None, obs: str | None = None) -> TrainResult:
    """Train `policy` (with `tokenizer`) on demonstrations of `tasks`; see the module docstring.

    Args:
        preset: a Preset or a preset name (default: $ICIL_PRESET).
        policy, tokenizer: names from POLICIES and TOKENIZERS (tokenizer None: the policy's
            default, i.e. `mlp` for ICRT and the CVAE for ACT).
        tasks: task names (default: the preset's kitchen tasks); ignored with `demos`.
        source: demonstration source ("generated" or "human").
        run_dir: folder for checkpoints, metrics and the policy; "auto" picks
            `runs/<preset>/<policy+tokenizer>__<tasks>__<source>__seed<k>`; None writes nothing.
        resume: continue from `<run_dir>/checkpoint.pt` if it exists.
        demos: demonstrations to train on instead of loading them (Demo-like objects).
        steps: optimizer steps (default: preset.train.steps).
        seed: overrides preset.seed.
        device: "cpu", "cuda", ... (default: cuda when available).
        policy_options: extra keyword options for the policy's constructor.
        stop_after: stop (after checkpointing) once this step is reached, as if killed there;
            used to test resuming.
        obs: observation kind of the demonstrations ("state", "rgb", "rgbd"); default the
            preset's `data.obs`, except that MCR, which needs images, reads "rgb" then.
    """
    preset = preset if isinstance(preset, Preset) else get_preset(preset)
    if seed is not None:
        preset = dataclasses.replace(preset, seed=seed)
    on_cpu = str(device or ("cuda" if torch.cuda.is_available() else "cpu")).startswith("cpu")
    with cpu_threads(preset.train.cpu_threads if on_cpu else 0):
        return _train_policy(preset, policy, tokenizer, tasks, source, run_dir, resume, demos,
                             steps, device, progress, policy_options, stop_after, obs)


def _train_policy(preset: Preset, policy: str, tokenizer: str | None, tasks: Sequence[str] | None,
                  source: str, run_dir: str | Path | None, resume: bool,
                  demos: Sequence[Any] | None, steps: int | None, device: str | None,
                  progress: bool, policy_options: Mapping[str, Any] | None,
                  stop_after: int | None, obs: str | None) -> TrainResult:
    from icil_paper.batching import DemoSet, batch_to
    from icil_paper.policies import make_policy, policy_label
    from icil_paper.policies.backbones import obs_spec_from_obs
    from icil_paper.seeding import seed_everything

    tc = preset.train
    total = tc.steps if steps is None else int(steps)
    device = torch.device(device or ("cuda" if torch.cuda.is_available() else "cpu"))
    rng = seed_everything(preset.seed)

    if demos is None:
        from icil_paper.policies import REGISTRY

        tasks = list(tasks or preset.data.kitchen_tasks)
        if obs is None:
            obs = preset.data.obs
            if obs == "state" and getattr(REGISTRY[policy], "needs_images", False):
                obs = "rgb"
        demos = load_training_demos(preset, tasks, source, progress=progress, obs=obs)
    else:
        tasks = sorted({str(getattr(d, "task", "task")) for d in demos})
    demos = list(demos)
    if not demos:
        raise ValueError("no demonstrations to train on")
    spec = obs_spec_from_obs(demos[0].obs)
    action_dim = int(np.asarray(demos[0].actions).shape[1])
    options: dict[str, Any] = {"query_len": tc.query_len,
                               "tokenizer_latent_dim": preset.tokenizer.latent_dim}
    if tokenizer is not None:
        options["tokenizer_options"] = tokenizer_options(tokenizer, preset.tokenizer)
    options.update(policy_options or {})
    model = make_policy(policy, spec, action_dim, preset.policy, tokenizer=tokenizer, **options)
    label = policy_label(policy, tokenizer)

    run_config = {"preset": preset.to_dict(), "policy": policy, "tokenizer": tokenizer,
                  "label": label, "tasks": list(tasks), "source": source, "seed": preset.seed,
                  "steps": total, "obs_spec": spec.to_dict(), "action_dim": action_dim,
                  "n_demos": len(demos), "policy_options": _jsonable(options)}
    if run_dir == "auto":
        run_dir = default_run_dir(preset, policy, tokenizer, tasks, source)
    run_dir = Path(run_dir) if run_dir is not None else None
    ckpt_path = run_dir / CHECKPOINT if run_dir else None
    resuming = bool(resume and ckpt_path is not None and ckpt_path.exists())
    if run_dir is not None:
        _check_run_config(run_dir, run_config, resuming)

    data: DemoSet = model.prepare(demos, pretrain=not resuming, progress=progress)
    model.to(device)
    optimizer = make_optimizer(model, tc.lr, tc.weight_decay, tc.betas)
    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, cosine_schedule(tc.warmup_steps, total))
    ema = EMA(model, tc.ema_decay) if tc.ema_decay else None
    start = 0
    if resuming:
        ckpt = torch.load(ckpt_path, map_location=device, weights_only=False)
        model.load_state_dict(ckpt["model"])
        optimizer.load_state_dict(ckpt["optimizer"])
        scheduler.load_state_dict(ckpt["scheduler"])
        if ema is not None and ckpt.get("ema") is not None:
            ema.load_state_dict(ckpt["ema"])
        _set_rng_state(rng, ckpt["rng"])
        start = int(ckpt["step"])
        _truncate_metrics(run_dir / METRICS_FILE, start)
    elif run_dir is not None:  # starting over: nothing of an earlier run may be resumed
        for name in (METRICS_FILE, CHECKPOINT, POLICY_FILE):
            (run_dir / name).unlink(missing_ok=True)

    def checkpoint(step: int) -> None:
        if ckpt_path is None:
            return
        save_torch(ckpt_path, {"step": step, "model": model.state_dict(),
                               "optimizer": optimizer.state_dict(),
                               "scheduler": scheduler.state_dict(),
                               "ema": ema.state_dict() if ema else None,
                               "rng": _rng_state(rng), "spec": model.spec, "config": run_config})

    from tqdm.auto import tqdm

    history: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    bar = tqdm(total=total, initial=start, desc=f"train {label}", disable=not progress,
               dynamic_ncols=True)
    last_loss = float("nan")
    step = start
    while step < total:
        model.train()
        batch = batch_to(model.sample_batch(data, tc.batch_size, rng), device)
        loss, info = model(batch)
        if not torch.isfinite(loss):
            raise FloatingPointError(f"non-finite loss {float(loss)} at step {step} of {label} "
                                     f"(parts: {info})")
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        grad_norm = torch.nn.utils.clip_grad_norm_(
            [p for p in model.parameters() if p.requires_grad], tc.grad_clip)
        optimizer.step()
        scheduler.step()
        if ema is not None:
            ema.update(model)
        step += 1
        last_loss = float(loss.detach())
        bar.update(1)
        if step % tc.log_every == 0 or step == total:
            line = {"step": step, "loss": last_loss, "lr": scheduler.get_last_lr()[0],
                    "grad_norm": float(grad_norm), **info,
                    "elapsed_s": round(time.perf_counter() - t0, 3)}
            history.append(line)
            bar.set_postfix(loss=f"{last_loss:.4f}")
            if run_dir is not None:
                with open(run_dir / METRICS_FILE, "a") as f:
                    f.write(json.dumps(line) + "\n")
        if step % tc.ckpt_every == 0 or step == total or step == stop_after:
            checkpoint(step)
        if stop_after is not None and step >= stop_after:
            break
    bar.close()
    wall = time.perf_counter() - t0

    if ema is not None:
        ema.copy_to(model)
    model.eval()
    done = step >= total
    if run_dir is not None and done:
        save_torch(run_dir / POLICY_FILE, {"spec": model.spec, "state_dict": model.state_dict(),
                                           "config": run_config, "step": step})
    trained_steps = step - start
    metrics = {"final_loss": last_loss if history else _last_logged_loss(run_dir),
               "steps": step, "wall_time_s": round(wall, 3),
               "steps_per_s": round(trained_steps / wall, 3) if trained_steps and wall > 0 else None,
               "n_params": sum(p.numel() for p in model.parameters()),
               "n_demos": len(demos), "device": str(device)}
    return TrainResult(model, run_dir, metrics, history)


def _jsonable(obj: Any) -> Any:
    return json.loads(json.dumps(obj, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))


def _check_run_config(run_dir: Path, config: dict[str, Any], resuming: bool) -> None:
    path = run_dir / CONFIG_FILE
    if resuming and path.exists():
        old = json.loads(path.read_text())
        if old != _jsonable(config):
            diff = sorted(k for k in set(old) | set(config) if old.get(k) != _jsonable(config).get(k))
            raise ValueError(f"{run_dir} holds a different run (differs in {diff}); pass another "
                             "run directory or resume=False to start over")
    atomic_write_json(path, config)


def _truncate_metrics(path: Path, step: int) -> None:
    """Keep metric lines up to `step` (lines logged after the checkpoint are redone)."""
    if not path.exists():
        return
    keep = [line for line in path.read_text().splitlines()
            if line.strip() and json.loads(line)["step"] <= step]
    atomic_write_bytes(path, ("\n".join(keep) + "\n" if keep else "").encode())


def _last_logged_loss(run_dir: Path | None) -> float | None:
    if run_dir is None or not (run_dir / METRICS_FILE).exists():
        return None
    lines = [json.loads(x) for x in (run_dir / METRICS_FILE).read_text().splitlines() if x.strip()]
    return lines[-1]["loss"] if lines else None


# --------------------------------------------------------------------------- CLI
def build_parser() -> argparse.ArgumentParser:
    from icil_paper.policies import POLICIES

    p = argparse.ArgumentParser(prog="icil-paper train",
                                description="Train a policy (ICRT or a baseline) with an action tokenizer.")
    p.add_argument("--preset", choices=PRESET_NAMES, default=None,
                   help="preset (default: $ICIL_PRESET or small)")
    p.add_argument("--seed", type=int, default=None, help="override the preset's seed")
    p.add_argument("--policy", default="icrt", help=f"one of {', '.join(POLICIES)}")
    p.add_argument("--tokenizer", default=None,
                   help="action tokenizer (icrt: default mlp; act: default none = CVAE)")
    p.add_argument("--tasks", nargs="+", default=None, help="task names (default: see --suite)")
    p.add_argument("--suite", choices=("kitchen", "maniskill"), default="kitchen",
                   help="train on every task of this suite when --tasks is not given")
    p.add_argument("--source", default="generated", help="demonstration source")
    p.add_argument("--obs", choices=("state", "rgb", "rgbd"), default=None,
                   help="observations to learn from (default: the preset's; mcr: rgb)")
    p.add_argument("--run-dir", default=None, help="run folder (default: runs/<preset>/...)")
    resume = p.add_mutually_exclusive_group()
    resume.add_argument("--resume", action="store_true",
                        help="continue from the run folder's last checkpoint (the default)")
    resume.add_argument("--no-resume", action="store_true",
                        help="start over even if a checkpoint exists")
    p.add_argument("--steps", type=int, default=None, help="override preset.train.steps")
    p.add_argument("--device", default=None, help="cpu or cuda (default: cuda when available)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def main(argv: list[str] | None = None) -> int:
    """`icil-paper train`: train, write the run folder, store a `train` record."""
    from icil_paper.policies import policy_label
    from icil_paper.results import ResultsStore

    args = build_parser().parse_args(argv)
    preset = get_preset(active_preset_name(args.preset), seed=args.seed)
    tasks = args.tasks or list(getattr(preset.data, f"{args.suite}_tasks"))
    run_dir = args.run_dir or default_run_dir(preset, args.policy, args.tokenizer, tasks, args.source)
    result = train_policy(preset, args.policy, args.tokenizer, tasks, args.source, run_dir=run_dir,
                          resume=not args.no_resume, steps=args.steps, device=args.device,
                          progress=not args.quiet, obs=args.obs)
    label = policy_label(args.policy, args.tokenizer)
    config = json.loads((Path(run_dir) / CONFIG_FILE).read_text())
    metrics = {k: v for k, v in result.metrics.items() if k != "device"}
    metrics["policy_digest"] = policy_digest(result.policy)
    metrics["run_dir"] = str(run_dir)
    store = ResultsStore(preset.name)
    path = store.write("train", f"{label}__{suite_of(tasks)}__{args.source}", config,
                       _finite(metrics), preset.seed, result.metrics["wall_time_s"])
    print(f"trained {label} for {result.metrics['steps']} steps on {len(tasks)} task(s): "
          f"final loss {result.metrics['final_loss']}, policy in {run_dir}/{POLICY_FILE}; "
          f"record {path}")
    return 0


def _finite(metrics: Mapping[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in metrics.items()}


if __name__ == "__main__":
    sys.exit(main())
