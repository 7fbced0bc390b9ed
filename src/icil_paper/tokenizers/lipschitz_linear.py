"""Row-wise Lipschitz weight normalization (Eq. 4 of the paper; Liu et al. 2022).

    layer = LipschitzLinear(64, 64)     # y = W' x + b, with W' = Eq. 4 applied to W
    loss = lipschitz_loss(encoder)      # prod_l softplus(c_l): the paper's L_Lipschitz

For y = W x + b in the infinity norm the Lipschitz constant is the largest absolute row sum
of W. Eq. 4 rescales every row whose absolute sum exceeds a trainable bound softplus(c) down
to that bound and leaves the other rows alone:

    W_i  <-  W_i * min(1, softplus(c) / sum_j |W_ij|)

With 1-Lipschitz activations between them, a chain of such layers is Lipschitz with
constant at most prod_l softplus(c_l), the term `lipschitz_loss` returns.

Initialisation follows Liu et al.: W ~ randn * sqrt(2 / in_features), c at the largest
absolute row sum of W. `per_row=True, c_init=1.0, weight_init="randn"` is the official code's.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor, nn

WEIGHT_INITS = ("liu", "randn", "linear")
"""`LipschitzLinear`'s weight initialisations (`LipschitzOptions.weight_init`)."""


class LipschitzLinear(nn.Module):
    """A linear layer whose weight is row-normalized as in Eq. 4 on every forward pass.

    Args:
        in_features, out_features, bias: as for `torch.nn.Linear`.
        per_row: one bound per output row (the official code) instead of one per layer.
        c_init: initial value of c; None uses Liu et al.'s max absolute row sum of W.
        weight_init: "liu" (randn * sqrt(2 / in_features), zero bias), "randn" (the official
            code) or "linear" (`nn.Linear`'s, from the same random numbers: its twin).
        c_lr_scale: the learning rate of c as a multiple of the optimiser's (0: fixed).
    """

    def __init__(self, in_features: int, out_features: int, bias: bool = True,
                 per_row: bool = False, c_init: float | None = None,
                 weight_init: str = "liu", c_lr_scale: float = 1.0):
        super().__init__()
        if not (math.isfinite(c_lr_scale) and c_lr_scale >= 0):
            raise ValueError(f"c_lr_scale must be a finite number >= 0, got {c_lr_scale}")
        self.in_features = in_features
        self.out_features = out_features
        self.per_row = per_row
        self.c_lr_scale = float(c_lr_scale)
        bias_init = None
        if weight_init == "liu":
            weight = torch.randn(out_features, in_features) * math.sqrt(2.0 / in_features)
        elif weight_init == "randn":
            weight = torch.randn(out_features, in_features)
        elif weight_init == "linear":  # nn.Linear's, drawn in its order: a twin of nn.Linear
            weight = torch.empty(out_features, in_features)
            nn.init.kaiming_uniform_(weight, a=math.sqrt(5))
            if bias:
                bound = 1.0 / math.sqrt(in_features)
                bias_init = torch.empty(out_features).uniform_(-bound, bound)
        else:
            raise ValueError(f"unknown weight_init {weight_init!r}; valid: "
                             f"{', '.join(repr(w) for w in WEIGHT_INITS)}")
        self.weight = nn.Parameter(weight)  # (out, in), the unnormalized weight
        if bias:
            self.bias = nn.Parameter(bias_init if bias_init is not None
                                     else torch.zeros(out_features))
        else:
            self.bias = None
        shape = (out_features,) if per_row else ()
        if c_init is None:
            c = weight.abs().sum(dim=1).max().expand(shape).clone()
        else:
            c = torch.full(shape, float(c_init))
        self.c = nn.Parameter(c)

    def lipschitz_bound(self) -> Tensor:
        """softplus(c): this layer's bound in the infinity norm (the largest, if per row)."""
        bound = F.softplus(self.c)
        return bound.max() if self.per_row else bound

    def normalized_weight(self) -> Tensor:
        """W with every row's absolute sum capped at softplus(c) (Eq. 4); (out, in)."""
        row_sums = self.weight.abs().sum(dim=1).clamp_min(1e-12)  # (out,)
        scale = torch.clamp(F.softplus(self.c) / row_sums, max=1.0)  # (out,)
        return self.weight * scale.unsqueeze(1)

    def forward(self, x: Tensor) -> Tensor:
        return F.linear(x, self.normalized_weight(), self.bias)

    def extra_repr(self) -> str:
        return (f"in_features={self.in_features}, out_features={self.out_features}, "
                f"bias={self.bias is not None}, per_row={self.per_row}, "
                f"c_lr_scale={self.c_lr_scale:g}")


def lipschitz_layers(module: nn.Module) -> list[LipschitzLinear]:
    """Every LipschitzLinear inside `module`, in registration order."""
    return [m for m in module.modules() if isinstance(m, LipschitzLinear)]


def bound_parameter_groups(module: nn.Module, lr: float) -> list[dict]:
    """Optimiser parameter groups for the bounds c of `module`'s LipschitzLinear layers: one
    `{"params": [c, ...], "lr": lr * c_lr_scale, "weight_decay": 0.0}` per multiple (sorted).

    Never decayed: decay would pull softplus(c) towards 0.69, a pressure the paper lacks.
    """
    by_scale: dict[float, list[nn.Parameter]] = {}
    for layer in lipschitz_layers(module):
        if layer.c.requires_grad:
            by_scale.setdefault(layer.c_lr_scale, []).append(layer.c)
    return [{"params": params, "lr": lr * scale, "weight_decay": 0.0}
            for scale, params in sorted(by_scale.items())]


def lipschitz_loss(module: nn.Module) -> Tensor:
    """L_Lipschitz = prod_l softplus(c_l) over the LipschitzLinear layers of `module` (the
    bound of the chain's Lipschitz constant in the infinity norm; 1 without such layers)."""
    layers = lipschitz_layers(module)
    if not layers:
        return torch.ones(())
    return torch.stack([layer.lipschitz_bound() for layer in layers]).prod()


def lipschitz_bounds(module: nn.Module) -> list[float]:
    """The bound softplus(c_l) of each LipschitzLinear layer, as floats."""
    return [layer.lipschitz_bound().item() for layer in lipschitz_layers(module)]


def weight_norm_bound(module: nn.Module, ord: float = math.inf) -> float:
    """prod_l ||W_l|| over the (Lipschitz, plain or spectral-normalized) linear layers of
    `module`, with their effective weights: a bound of the network's Lipschitz constant in
    the norm `ord` (inf: largest absolute row sum; 2: largest singular value)."""
    if ord not in (math.inf, 2):
        raise ValueError(f"ord must be inf or 2, got {ord}")
    bound = 1.0
    with torch.no_grad():
        for m in module.modules():
            if isinstance(m, LipschitzLinear):
                weight = m.normalized_weight()
            elif isinstance(m, nn.Linear):
                weight = m.weight  # the normalized weight under a spectral_norm parametrization
            else:
                continue
            if ord == math.inf:
                bound *= weight.abs().sum(dim=1).max().item()
            else:
                bound *= torch.linalg.matrix_norm(weight, ord=2).item()
    return bound
