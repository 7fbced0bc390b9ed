"""The one training loop every policy shares.

    spec = run_spec(preset, "icrt", "lipvq", tasks=["kitchen/open_drawer"])
    result = train_policy(spec, run_dir=run_dir_for(spec, preset.name), preset=preset.name)
    result.policy.reset(prompt=demo); result.policy.select_action(obs)

One run: seed, load (or generate) the demonstrations, build and `prepare` the policy
(normalisation, tokenizer fitting, pre-training), then AdamW with warm-up and cosine decay,
gradient clipping and optional EMA, checkpointing every `ckpt_every` steps. A resumed run
on CPU equals an uninterrupted one bit for bit.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from icil_paper.data import ensure_many, load_dataset_file, load_demos
from icil_paper.policies import make_policy
from icil_paper.policies.batching import batch_to, obs_spec_from_obs
from icil_paper.seeding import cpu_threads, seed_everything
from icil_paper.timing import phase
from icil_paper.train import rundir
from icil_paper.train.optim import EMA, cosine_schedule, make_optimizer


@dataclass
class TrainResult:
    """What `train_policy` returns."""

    policy: Any
    """The trained policy (EMA weights when EMA is on), in eval mode."""
    run_dir: Path | None
    """Where checkpoints, metrics and the policy were written (None: nothing written)."""
    metrics: dict[str, Any] = field(default_factory=dict)
    """Final loss, steps, resumed_from_step, this call's wall time, steps per second,
    parameter count, demos, device."""
    history: list[dict[str, Any]] = field(default_factory=list)
    """The metric lines of this call (not of earlier, resumed-from calls)."""


@dataclass
class TrainState:
    """Everything the loop changes, and so everything a checkpoint holds."""

    model: Any
    optimizer: torch.optim.Optimizer
    scheduler: torch.optim.lr_scheduler.LRScheduler
    ema: EMA | None
    rng: np.random.Generator
    step: int = 0

    def state_dict(self, key: str) -> dict[str, Any]:
        return {"step": self.step, "key": key, "model": self.model.state_dict(),
                "optimizer": self.optimizer.state_dict(),
                "scheduler": self.scheduler.state_dict(),
                "ema": self.ema.state_dict() if self.ema else None,
                "rng": rundir.rng_state(self.rng)}

    def load_state_dict(self, ckpt: Mapping[str, Any]) -> None:
        self.model.load_state_dict(ckpt["model"])
        self.optimizer.load_state_dict(ckpt["optimizer"])
        self.scheduler.load_state_dict(ckpt["scheduler"])
        if self.ema is not None and ckpt.get("ema") is not None:
            self.ema.load_state_dict(ckpt["ema"])
        rundir.set_rng_state(self.rng, ckpt["rng"])
        self.step = int(ckpt["step"])


def training_demos(data: Any, preset: Any = None, workers: int = 1,
                   progress: bool = True) -> list[Any]:
    """The demonstrations a DataSpec names (generated where missing), or its `dataset` file's;
    `preset` (a Preset or a name) locates the data sets."""
    if data.dataset is not None:
        return list(load_dataset_file(data.dataset, obs_keys=data.obs_keys))

    if preset is None:
        raise ValueError("training_demos needs the preset (preset=...): its data sets "
                         "live under data/<preset>/; or pass the demonstrations (demos=...)")
    by_count: dict[int, list[str]] = {}
    for task in data.tasks:
        by_count.setdefault(data.demos_for(task), []).append(task)
    paths = {}
    for n, tasks in by_count.items():
        paths |= ensure_many(preset, tasks, [data.source], n=n, workers=workers,
                             progress=progress, seed=data.seed, obs=data.obs)
    demos = [demo for task in data.tasks
             for demo in load_demos(paths[task, data.source], limit=data.demos_for(task))]
    if not demos:
        raise ValueError(f"no demonstrations for tasks {list(data.tasks)} from source "
                         f"{data.source!r}")
    return demos


def train_policy(spec: Any, run_dir: str | Path | None = None, resume: bool = True,
                 demos: Sequence[Any] | None = None, device: str | None = None,
                 progress: bool = True, stop_after: int | None = None,
                 preset: Any = None, data_workers: int = 1) -> TrainResult:
    """Train the policy a RunSpec describes.

    `run_dir` (None: write nothing) receives config, checkpoints, metrics and the policy;
    `demos` replaces the spec's demonstrations; `stop_after` stops (after checkpointing) at
    that step, as if killed; `preset` locates the data sets unless `demos` is given.
    """
    device = torch.device(device or ("cuda" if torch.cuda.is_available() else "cpu"))
    threads = spec.train.cpu_threads if device.type == "cpu" else 0
    run_dir = Path(run_dir) if run_dir is not None else None
    with cpu_threads(threads), (rundir.run_lock(run_dir) if run_dir is not None
                                else contextlib.nullcontext()):
        return _train(spec, run_dir, resume, demos, device, progress, stop_after, preset,
                      data_workers)


def _train(spec, run_dir, resume, demos, device, progress, stop_after, preset,
           data_workers) -> TrainResult:
    tc = spec.train
    if run_dir is not None:  # before any work: a wrong folder fails fast
        rundir.prepare_run_dir(run_dir, spec, resume)
    rng = seed_everything(spec.seed)
    with phase("train.data"):
        demos = list(demos) if demos is not None else training_demos(spec.data, preset,
                                                                       data_workers, progress)
    if not demos:
        raise ValueError("no demonstrations to train on")
    spec.policy.check_episode_length(max(len(d.actions) for d in demos))  # before any step
    obs_spec = obs_spec_from_obs(demos[0].obs)
    action_dim = int(np.asarray(demos[0].actions).shape[1])
    key = spec.key()
    with phase("train.checkpoint"):
        ckpt = rundir.load_checkpoint(run_dir, key, device) if run_dir and resume else None
    with phase("train.prepare"):  # normalisation, tokenizer fitting, MCR's pre-training
        model = make_policy(spec.policy, obs_spec, action_dim, spec.tokenizer)
        data = model.prepare(demos, pretrain=ckpt is None, progress=progress)
        model.to(device)
    optimizer = make_optimizer(model, tc.lr, tc.weight_decay, tc.betas)
    scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer,
                                                  cosine_schedule(tc.warmup_steps, tc.steps))
    state = TrainState(model, optimizer, scheduler, EMA(model, tc.ema_decay) if tc.ema_decay
                       else None, rng)
    metrics_path = run_dir / rundir.METRICS_FILE if run_dir else None
    if ckpt is not None:
        state.load_state_dict(ckpt)
        rundir.truncate_metrics(metrics_path, state.step)
    start = state.step

    history: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    bar = tqdm(total=tc.steps, initial=start, desc=f"train {spec.label}", disable=not progress,
               dynamic_ncols=True)
    last_loss = float("nan")
    while state.step < tc.steps:
        with phase("train.step"):
            loss, info, grad_norm = _step(state, data, tc, device, batch_to)
        last_loss = float(loss)
        bar.update(1)
        step = state.step
        if step % tc.log_every == 0 or step == tc.steps:
            line = {"step": step, "loss": last_loss, "lr": scheduler.get_last_lr()[0],
                    "grad_norm": grad_norm, **info,
                    "elapsed_s": round(time.perf_counter() - t0, 3)}
            history.append(line)
            bar.set_postfix(loss=f"{last_loss:.4f}")
            if metrics_path is not None:
                with phase("train.log"):
                    rundir.append_metrics(metrics_path, line)
        if run_dir is not None and (step % tc.ckpt_every == 0 or step == tc.steps
                                    or step == stop_after):
            with phase("train.checkpoint"):
                rundir.save_checkpoint(run_dir, state.state_dict(key))
        if stop_after is not None and step >= stop_after:
            break
    bar.close()
    wall = time.perf_counter() - t0

    if state.ema is not None:
        state.ema.copy_to(model)
    model.eval()
    trained = state.step - start
    if history:
        final_loss = last_loss
    else:
        logged = rundir.read_metrics(metrics_path) if metrics_path else []
        final_loss = logged[-1]["loss"] if logged else None
    metrics = {"final_loss": final_loss, "steps": state.step, "resumed_from_step": start,
               "wall_time_s": round(wall, 3),
               "steps_per_s": round(trained / wall, 3) if trained and wall > 0 else None,
               "n_params": model.n_params(), "n_demos": len(demos), "device": str(device)}
    if run_dir is not None and state.step >= tc.steps:
        with phase("train.checkpoint"):
            rundir.save_policy(run_dir / rundir.POLICY_FILE, model,
                               {"key": key, "spec": spec.to_dict(), "steps": state.step})
    return TrainResult(model, run_dir, metrics, history)


def _step(state: TrainState, data: Any, tc: Any, device: torch.device, batch_to) -> tuple:
    """One optimiser step; returns (loss, info, grad norm)."""
    model = state.model
    model.train()
    batch = batch_to(model.sample_batch(data, tc.batch_size, state.rng), device)
    loss, info = model(batch)
    if not torch.isfinite(loss):
        raise FloatingPointError(f"non-finite loss {float(loss)} at step {state.step} "
                                 f"(parts: {info})")
    state.optimizer.zero_grad(set_to_none=True)
    loss.backward()
    grad_norm = torch.nn.utils.clip_grad_norm_(
        [p for p in model.parameters() if p.requires_grad], tc.grad_clip)
    state.optimizer.step()
    state.scheduler.step()
    if state.ema is not None:
        state.ema.update(model)
    state.step += 1
    return loss.detach(), info, float(grad_norm)


def finite(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """Metrics with non-finite floats replaced by None (the results store refuses NaN)."""
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in metrics.items()}
