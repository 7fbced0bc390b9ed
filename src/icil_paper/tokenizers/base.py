"""The one interface every action tokenizer implements.

An action tokenizer turns a batch of action trajectories into one embedding per step, the
action tokens that the policy interleaves with its observation tokens (Eq. 1 of the paper),
and knows how to turn embeddings back into actions:

    tokenizer = make_tokenizer(LipVQConfig(latent_dim=64), action_dim=7)
    tokenizer.fit(trajectories)            # bin ranges, FAST's BPE; no-op for learned ones
    out = tokenizer(actions)               # actions (B, T, A)
    out.embeddings                         # (B, T, D)  what the policy consumes
    out.reconstruction                     # (B, T, A)  the tokenizer's own reconstruction
    out.codes                              # LongTensor of discrete codes, or None
    loss = policy_loss + sum(out.losses.values())   # weighted scalars
    actions_back = tokenizer.decode(out.embeddings) # (B, T, A)

Input checks are the same for every tokenizer: a wrong action dimension or a NaN/inf
value raises a ValueError that names the problem.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.tokenizers.configs import (
    TOKENIZER_REGISTRY,
    LipschitzOptions,
    TokenizerConfig,
)
from icil_paper.tokenizers.lipschitz_linear import LipschitzLinear, lipschitz_loss


@dataclass
class TokenizerOutput:
    """What `ActionTokenizer.forward` returns."""

    embeddings: Tensor
    """(B, T, D) action tokens the policy consumes (gradients flow where the method allows)."""
    reconstruction: Tensor
    """(B, T, A) the tokenizer's own reconstruction (decoder, bin centres or inverse DCT)."""
    codes: Tensor | None
    """LongTensor codes, None for continuous tokenizers: (B, T) for vq / lfq / fsq, (B, T, A)
    for bin, (B, T, Q) for rvq, (B, T, K * A) for bspline, (B, T or ceil(T / chunk), L)
    padded with -1 for fast."""
    losses: dict[str, Tensor] = field(default_factory=dict)
    """Weighted scalar losses; a policy trained jointly adds their sum to its own loss."""
    latents: Tensor | None = None
    """(B, T, D') encoder output before quantization, where there is an encoder."""

    def total_loss(self) -> Tensor:
        """Sum of `losses` (a zero tensor when there are none)."""
        if not self.losses:
            return self.embeddings.new_zeros(())
        return torch.stack(list(self.losses.values())).sum()


ENCODER_NORMS = ("none", "lipschitz", "lipschitz-last", "spectral")
_ACTIVATIONS = {"relu": nn.ReLU, "gelu": nn.GELU}
_OUTPUT_ACTIVATIONS = {"none": nn.Identity, "sigmoid": nn.Sigmoid, "tanh": nn.Tanh}


def activation_class(name: str) -> type[nn.Module]:
    """`relu` or `gelu` as a module class (ValueError naming the valid ones otherwise)."""
    if name not in _ACTIVATIONS:
        raise ValueError(f"unknown activation {name!r}; valid: {', '.join(_ACTIVATIONS)}")
    return _ACTIVATIONS[name]


def build_encoder(sizes: Sequence[int], norm: str = "none", activation: str = "relu",
                  output_activation: str = "none",
                  lipschitz: LipschitzOptions | None = None) -> nn.Sequential:
    """An encoder MLP with the weight normalisation `norm` of its linear layers: `none`,
    `lipschitz` (every layer a LipschitzLinear, Eq. 4), `lipschitz-last` (the official
    code) or `spectral` (Miyato et al. 2018)."""
    if norm not in ENCODER_NORMS:
        raise ValueError(f"unknown encoder norm {norm!r}; valid: {', '.join(ENCODER_NORMS)}")
    options = lipschitz or LipschitzOptions()
    act = activation_class(activation)
    n_layers = len(sizes) - 1
    layers: list[nn.Module] = []
    for i, (n_in, n_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=False)):
        last = i == n_layers - 1
        if norm == "lipschitz" or (norm == "lipschitz-last" and last):
            layer = LipschitzLinear(n_in, n_out, per_row=options.per_row, c_init=options.c_init,
                                    weight_init=options.weight_init,
                                    c_lr_scale=options.c_lr_scale)
        elif norm == "spectral":
            layer = nn.utils.parametrizations.spectral_norm(nn.Linear(n_in, n_out))
        else:
            layer = nn.Linear(n_in, n_out)
        layers.append(layer)
        if not last:
            layers.append(act())
    if output_activation != "none":
        layers.append(_OUTPUT_ACTIVATIONS[output_activation]())
    return nn.Sequential(*layers)


LIPSCHITZ_NORMS = ("lipschitz", "lipschitz-last")


def lipschitz_losses(encoder: nn.Module, config) -> dict[str, Tensor]:
    """Eq. 5's Lipschitz term of an encoder built with `config.norm`: {"lipschitz":
    gamma * prod_l softplus(c_l)} when the norm is a Lipschitz one and gamma > 0, else {}."""
    weight = config.lipschitz.weight
    if config.norm not in LIPSCHITZ_NORMS or not weight:
        return {}
    return {"lipschitz": weight * lipschitz_loss(encoder)}


@contextmanager
def evaluating(module: nn.Module) -> Iterator[nn.Module]:
    """`module` in eval mode and without gradients inside the block, its mode restored after."""
    was_training = module.training
    module.eval()
    try:
        with torch.no_grad():
            yield module
    finally:
        module.train(was_training)


def causal_chunks(actions: Tensor, chunk: int) -> Tensor:
    """(B, T, A) -> (B, T, C, A): the C = `chunk` actions ending at each step, the first
    action repeated before the start (`fast`, `bspline`)."""
    padded = torch.cat([actions[:, :1].expand(-1, chunk - 1, -1), actions], dim=1)
    return padded.unfold(1, chunk, 1).transpose(-1, -2)


def as_trajectory_list(actions, action_dim: int) -> list[np.ndarray]:
    """`fit` input (an array or tensor (N, T, A), or a list of (T_i, A) arrays) as a list of
    float64 arrays (T_i, A); ValueError naming the problem."""
    if isinstance(actions, (np.ndarray, Tensor)):
        if actions.ndim not in (2, 3):
            raise ValueError(f"actions must be shaped (N, T, A) or be a list of (T, A) arrays; "
                             f"got an array with shape {tuple(actions.shape)}")
        actions = [actions] if actions.ndim == 2 else list(actions)
    trajectories = []
    for i, traj in enumerate(actions):
        traj = np.asarray(traj.detach().cpu() if isinstance(traj, Tensor) else traj, np.float64)
        if traj.ndim != 2:
            raise ValueError(f"trajectory {i} must be shaped (T, A), got shape {traj.shape}")
        if traj.shape[1] != action_dim:
            raise ValueError(f"wrong action dimension: trajectory {i} has {traj.shape[1]} "
                             f"action dimensions, the tokenizer expects {action_dim}")
        if not np.isfinite(traj).all():
            raise ValueError(f"trajectory {i} contains NaN or inf actions "
                             f"(first at row {int(np.argwhere(~np.isfinite(traj))[0, 0])})")
        if len(traj) == 0:
            raise ValueError(f"trajectory {i} is empty")
        trajectories.append(traj)
    if not trajectories:
        raise ValueError("no trajectories to fit")
    return trajectories


class ActionTokenizer(nn.Module):
    """Base class: input validation, fitting, and the shared `decode`.

    Built from its config alone. Subclasses set `name` and `discrete`, and implement
    `_forward(actions) -> TokenizerOutput` and, with something to fit, `_fit(trajectories)`.
    """

    name: str = "base"
    discrete: bool = False
    needs_fit: bool = False

    def __init__(self, config: TokenizerConfig, action_dim: int):
        super().__init__()
        if action_dim < 1:  # the config checks its own fields when it is built
            raise ValueError(f"action_dim must be positive, got {action_dim}")
        self.config = config
        self.action_dim = int(action_dim)
        self.latent_dim = int(config.latent_dim)
        # A buffer (not a Python bool) so that a loaded checkpoint knows it was fitted.
        self.register_buffer("_fitted", torch.tensor(not self.needs_fit), persistent=True)

    # ----------------------------------------------------------------- fitting
    @property
    def fitted(self) -> bool:
        """True once `fit` has run (always True for tokenizers with nothing to fit)."""
        return bool(self._fitted)

    def fit(self, actions) -> ActionTokenizer:
        """Fit what must be fitted to actions (N, T, A) or [(T_i, A)] before training."""
        trajectories = as_trajectory_list(actions, self.action_dim)
        self._fit(trajectories)
        self._fitted.fill_(True)
        return self

    def _fit(self, trajectories: list[np.ndarray]) -> None:
        """Nothing to fit for learned tokenizers."""

    @torch.no_grad()
    def _set_range(self, low: Tensor, high: Tensor) -> None:
        """Store (A,) bounds in the `low` / `high` buffers (bin, bspline); a constant dimension
        still gets a non-empty range."""
        low, high = low.clone(), high.clone()  # copied into the buffers' dtype below
        flat = high - low < 1e-6
        low[flat] -= 1e-3
        high[flat] += 1e-3
        self.low.copy_(low)
        self.high.copy_(high)

    # ----------------------------------------------------------------- forward
    def check_actions(self, actions: Tensor) -> Tensor:
        """Raise ValueError for a wrong shape, wrong action dimension or NaN/inf values."""
        if not isinstance(actions, Tensor):
            actions = torch.as_tensor(np.asarray(actions), dtype=torch.float32)
        if actions.ndim != 3:
            raise ValueError(f"actions must be shaped (B, T, A), got shape {tuple(actions.shape)}")
        if actions.shape[-1] != self.action_dim:
            raise ValueError(f"wrong action dimension: got actions with {actions.shape[-1]} "
                             f"dimensions, the {self.name} tokenizer expects {self.action_dim}")
        if actions.shape[0] == 0 or actions.shape[1] == 0:
            raise ValueError(f"empty batch of actions (shape {tuple(actions.shape)}): give at "
                             "least one trajectory of at least one step")
        if not torch.isfinite(actions).all():
            bad = (~torch.isfinite(actions)).nonzero()[0].tolist()
            raise ValueError(f"actions contain NaN or inf values (first at index {bad})")
        if not self.fitted:
            raise RuntimeError(f"the {self.name} tokenizer must be fitted first: "
                               "call tokenizer.fit(trajectories)")
        return actions.to(self._param_dtype())

    def _param_dtype(self) -> torch.dtype:
        return next((p.dtype for p in self.parameters()), torch.float32)

    def forward(self, actions: Tensor) -> TokenizerOutput:
        """Tokenize actions (B, T, A) -> TokenizerOutput (see the module docstring)."""
        return self._forward(self.check_actions(actions))

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        raise NotImplementedError

    def decode_losses(self, z: Tensor, actions: Tensor) -> dict[str, Tensor]:
        """{"decode": weighted MSE of the learned head `decoder` on embeddings z (B, T, D)},
        detached unless the config's `autoencode` (bin, fast, bspline)."""
        decoded = self.decoder(z if self.config.autoencode else z.detach())
        return {"decode": self.config.decode_weight * F.mse_loss(decoded, actions)}

    def decode(self, embeddings: Tensor) -> Tensor:
        """Actions (B, T, A) from embeddings (B, T, D)."""
        if embeddings.ndim != 3 or embeddings.shape[-1] != self.latent_dim:
            raise ValueError(f"embeddings must be shaped (B, T, {self.latent_dim}), got "
                             f"{tuple(embeddings.shape)}")
        return self.decoder(embeddings)

    # ----------------------------------------------------------------- facts
    @property
    def codebook_size(self) -> int | None:
        """Number of distinct codes (None for continuous tokenizers)."""
        return None

    @property
    def context_steps(self) -> int:
        """How many of the latest actions one step's embedding depends on (1 per step): to
        embed a new step, pass at least this many and keep the last embedding."""
        return 1

    def tokens_per_step(self, actions=None) -> float:
        """Discrete tokens emitted per action step (1 embedding per step for continuous ones)."""
        return 1.0

    def vocabulary_ids(self, codes: Tensor) -> Tensor:
        """Codes from `forward` as a flat LongTensor of ids in [0, codebook_size) (no padding)."""
        return codes[codes >= 0].flatten()

    def codes_by_level(self, codes: Tensor) -> list[Tensor] | None:
        """Each level's codes, flat, for residual VQ; None for one codebook."""
        return None

    def no_weight_decay(self) -> list[nn.Parameter]:
        """Parameters the optimiser must not decay (none unless a config asks for it)."""
        return []

    def extra_repr(self) -> str:
        return f"action_dim={self.action_dim}, latent_dim={self.latent_dim}"


PROBE_SHAPE = (2, 16, 7)
"""(B, T, A) of the random actions a plugin's tokenizer is probed with (`probe`)."""


def probe(config: TokenizerConfig) -> str | None:
    """What is wrong with the tokenizer `config` builds, in words, or None: built, fitted and
    run on random actions PROBE_SHAPE, it must give embeddings (B, T, latent_dim) and a
    reconstruction (B, T, A). Run on every tokenizer a plugin registers."""
    try:
        problem = _probe_problem(config, PROBE_SHAPE)
    except Exception as exc:  # noqa: BLE001 - whatever a plugin's code raises is its problem
        text = " ".join(str(exc).split())
        problem = f"raises {type(exc).__name__}: {text}" if text else \
            f"raises {type(exc).__name__}"
    return (f"on a probe batch of actions shaped {PROBE_SHAPE}, {problem}; fix its encoder"
            if problem else None)


def _probe_problem(config: TokenizerConfig, shape: tuple[int, int, int]) -> str | None:
    b, t, a = shape
    tok = TOKENIZER_REGISTRY[config.type](config, a)
    if not isinstance(tok, ActionTokenizer):
        return f"builds a {type(tok).__name__}, not an ActionTokenizer"
    rng = np.random.default_rng(0)
    if not tok.fitted:
        tok.fit(rng.uniform(-1, 1, size=(4, t, a)))
    with torch.no_grad():
        out = tok(torch.as_tensor(rng.uniform(-1, 1, size=shape), dtype=torch.float32))
    if not isinstance(out, TokenizerOutput):
        return f"returns a {type(out).__name__}, not a TokenizerOutput"
    if tuple(out.embeddings.shape) != (b, t, config.latent_dim):
        return (f"returns embeddings of shape {tuple(out.embeddings.shape)}, expected "
                f"(B, T, latent_dim) = {(b, t, config.latent_dim)}")
    if tuple(out.reconstruction.shape) != shape:
        return (f"returns a reconstruction of shape {tuple(out.reconstruction.shape)}, "
                f"expected (B, T, A) = {shape}")
    return None


TOKENIZER_REGISTRY.probe = probe
