"""`vq`: VQ-VAE (van den Oord et al. 2017) over single actions; also the body of `lipvq`.

    actions x (B, T, A) --encoder q_theta--> z_e (B, T, D)
        --nearest codebook entry (L2), Eq. 2--> z_q = e_k, k = argmin_j ||z_e - e_j||^2
        --straight-through: z_q + (z_e - sg[z_e])--> embeddings (B, T, D) --decoder--> x_hat

Losses (Sec. III-B; squared errors are means over elements):

    L = L_rec + alpha L_codebook + beta L_commit + gamma L_Lipschitz
    L_rec      = ||x_hat - x||^2
    L_codebook = ||sg[z_e] - z_q||^2        (moves codes towards encoder outputs)
    L_commit   = ||z_e - sg[z_q]||^2        (keeps the encoder near its codes)
    L_Lipschitz = prod_l softplus(c_l)      (only with Lipschitz layers)

with alpha = 1.0, beta = 0.25, gamma = 1e-6. The embeddings the policy consumes are the
quantized codebook vectors, with straight-through gradients so that the policy's loss also
reaches the encoder.

`norm` picks the encoder's weight normalization: "none" (VQ-VAE), "lipschitz" (every
linear layer a LipschitzLinear, Eq. 5: LipVQ-VAE as the paper writes it), "lipschitz-last"
(only the last layer, as in the official code) or "spectral" (spectral normalization,
Miyato et al. 2018, for chapter 02's comparison; it bounds the 2-norm Lipschitz constant
by 1 per layer instead of the infinity norm by a learned bound).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput, mlp
from icil_paper.tokenizers.lipschitz_linear import LipschitzLinear, lipschitz_loss
from icil_paper.tokenizers.mlp import DEFAULT_HIDDEN

NORMS = ("none", "lipschitz", "lipschitz-last", "spectral")
_ACTIVATIONS = {"relu": nn.ReLU, "gelu": nn.GELU}
_OUTPUT_ACTIVATIONS = {None: nn.Identity, "none": nn.Identity, "sigmoid": nn.Sigmoid,
                       "tanh": nn.Tanh}


def build_encoder(sizes: Sequence[int], norm: str = "none", activation: str = "relu",
                  output_activation: str | None = None, **lipschitz_options) -> nn.Sequential:
    """Encoder MLP with the chosen weight normalization (see the module docstring).

    `lipschitz_options` go to every LipschitzLinear (per_row, c_init, weight_init).
    """
    if norm not in NORMS:
        raise ValueError(f"unknown encoder norm {norm!r}; valid: {', '.join(NORMS)}")
    act = _ACTIVATIONS[activation]
    n_layers = len(sizes) - 1
    layers: list[nn.Module] = []
    for i, (n_in, n_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=False)):
        last = i == n_layers - 1
        if norm == "lipschitz" or (norm == "lipschitz-last" and last):
            layer = LipschitzLinear(n_in, n_out, **lipschitz_options)
        elif norm == "spectral":
            layer = nn.utils.parametrizations.spectral_norm(nn.Linear(n_in, n_out))
        else:
            layer = nn.Linear(n_in, n_out)
        layers.append(layer)
        if not last:
            layers.append(act())
    layers.append(_OUTPUT_ACTIVATIONS[output_activation]())
    return nn.Sequential(*layers)


class VQTokenizer(ActionTokenizer):
    """VQ-VAE action tokenizer (one code per step).

    Args:
        action_dim, latent_dim: A and D (D is also the codebook vector width).
        codebook_size: K (the paper: 1024).
        hidden: encoder hidden widths; the decoder mirrors them.
        norm: encoder weight normalization, one of NORMS.
        codebook_weight, commitment_weight, lipschitz_weight, recon_weight: alpha, beta,
            gamma and the reconstruction weight.
        straight_through: pass decoder/policy gradients to the encoder through the quantizer.
        detach_embeddings: give the policy `sg[z_q]` (the official code) instead.
        activation: "relu" (paper) or "gelu" (official code).
        output_activation: None (paper) or "sigmoid" (official code).
        decoder_hidden: decoder hidden widths (default: `hidden` reversed).
        lipschitz_options: passed to LipschitzLinear (per_row, c_init, weight_init).
        codebook_init: "uniform" (VQ-VAE's U(-1/K, 1/K), the default) or "data": on the first
            training batch, set the codes to randomly drawn encoder outputs (an opt-in
            remedy for codebook collapse; not part of the paper's method).
    """

    name = "vq"
    discrete = True

    def __init__(self, action_dim: int, latent_dim: int, codebook_size: int = 1024,
                 hidden: Sequence[int] = DEFAULT_HIDDEN, norm: str = "none",
                 codebook_weight: float = 1.0, commitment_weight: float = 0.25,
                 lipschitz_weight: float = 1e-6, recon_weight: float = 1.0,
                 straight_through: bool = True, detach_embeddings: bool = False,
                 activation: str = "relu", output_activation: str | None = None,
                 decoder_hidden: Sequence[int] | None = None,
                 lipschitz_options: dict | None = None, codebook_init: str = "uniform"):
        super().__init__(action_dim, latent_dim)
        if codebook_init not in ("uniform", "data"):
            raise ValueError(f"unknown codebook_init {codebook_init!r}; valid: 'uniform', 'data'")
        if codebook_size < 2:
            raise ValueError(f"codebook_size must be at least 2, got {codebook_size}")
        self.norm = norm
        self.codebook_weight = codebook_weight
        self.commitment_weight = commitment_weight
        self.lipschitz_weight = lipschitz_weight
        self.recon_weight = recon_weight
        self.straight_through = straight_through
        self.detach_embeddings = detach_embeddings
        self.encoder = build_encoder([action_dim, *hidden, latent_dim], norm, activation,
                                     output_activation, **(lipschitz_options or {}))
        dec_hidden = list(hidden[::-1] if decoder_hidden is None else decoder_hidden)
        self.decoder = mlp([latent_dim, *dec_hidden, action_dim],
                           activation=_ACTIVATIONS[activation])
        self.codebook = nn.Embedding(codebook_size, latent_dim)
        # VQ-VAE's initialisation: uniform in (-1/K, 1/K).
        nn.init.uniform_(self.codebook.weight, -1.0 / codebook_size, 1.0 / codebook_size)
        self.codebook_init = codebook_init
        self.register_buffer("_codebook_from_data", torch.tensor(False))

    @property
    def codebook_size(self) -> int:
        return self.codebook.num_embeddings

    def quantize(self, z_e: Tensor) -> tuple[Tensor, Tensor]:
        """Nearest codebook entry in L2 (Eq. 2): z_e (..., D) -> (z_q (..., D), codes (...))."""
        flat = z_e.reshape(-1, z_e.shape[-1])  # (N, D)
        weight = self.codebook.weight  # (K, D)
        dist = (flat.pow(2).sum(1, keepdim=True) - 2 * flat @ weight.t()
                + weight.pow(2).sum(1).unsqueeze(0))  # (N, K)
        codes = dist.argmin(dim=1)
        z_q = self.codebook(codes).view_as(z_e)
        return z_q, codes.view(z_e.shape[:-1])

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z_e = self.encoder(actions)  # (B, T, D)
        if self.codebook_init == "data" and self.training and not self._codebook_from_data:
            self._init_codebook_from(z_e.detach())
        z_q, codes = self.quantize(z_e)  # (B, T, D), (B, T)
        if self.straight_through:
            # Written as z_q + (z_e - sg[z_e]) rather than z_e + sg[z_q - z_e]: the same
            # gradient, but the value is exactly the codebook vector (no rounding residue).
            z = z_q + (z_e - z_e.detach())
        else:
            z = z_q  # gradients reach the codebook only, never the encoder
        recon = self.decoder(z)  # (B, T, A)
        losses = {
            "reconstruction": self.recon_weight * F.mse_loss(recon, actions),
            "codebook": self.codebook_weight * F.mse_loss(z_q, z_e.detach()),
            "commitment": self.commitment_weight * F.mse_loss(z_e, z_q.detach()),
        }
        if self.norm in ("lipschitz", "lipschitz-last") and self.lipschitz_weight:
            losses["lipschitz"] = self.lipschitz_weight * lipschitz_loss(self.encoder)
        embeddings = z.detach() if self.detach_embeddings else z
        return TokenizerOutput(embeddings=embeddings, reconstruction=recon, codes=codes,
                               losses=losses, latents=z_e)

    @torch.no_grad()
    def _init_codebook_from(self, z_e: Tensor) -> None:
        flat = z_e.reshape(-1, z_e.shape[-1])
        idx = torch.randint(len(flat), (self.codebook_size,), device=flat.device)
        noise = 1e-3 * flat.std() * torch.randn_like(self.codebook.weight)
        self.codebook.weight.copy_(flat[idx] + noise)
        self._codebook_from_data.fill_(True)

    @torch.no_grad()
    def encode_codes(self, actions: Tensor) -> Tensor:
        """Codes (B, T) of actions (B, T, A)."""
        return self.quantize(self.encoder(self.check_actions(actions)))[1]
