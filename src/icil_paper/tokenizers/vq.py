"""`vq`: VQ-VAE (van den Oord et al. 2017) over single actions; also the body of `lipvq`.

    actions x (B, T, A) --encoder q_theta--> z_e (B, T, D)
        --nearest codebook entry (L2), Eq. 2--> z_q = e_k, k = argmin_j ||z_e - e_j||^2
        --straight-through: z_e + sg[z_q - z_e]--> embeddings (B, T, D) --decoder--> x_hat

Losses (Eq. 5; squared errors are means over elements), alpha = 1, beta = 0.25, gamma = 1e-6:

    L = L_rec + alpha L_codebook + beta L_commit + gamma L_Lipschitz
    L_rec      = ||x_hat - x||^2
    L_codebook = ||sg[z_e] - z_q||^2        (moves codes towards encoder outputs)
    L_commit   = ||z_e - sg[z_q]||^2        (keeps the encoder near its codes)
    L_Lipschitz = prod_l softplus(c_l)      (only with Lipschitz layers)

Options (`VQConfig`): `straight_through`, `norm` (Eq. 4 on every layer gives LipVQ-VAE), and
remedies for codebook collapse, all off by default: `codebook_init="data"`,
`dead_code_restart=N` and `codebook_weight_decay=False`.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import (
    ActionTokenizer,
    TokenizerOutput,
    activation_class,
    build_encoder,
    lipschitz_losses,
)
from icil_paper.tokenizers.configs import VQConfig, register_tokenizer_model


@register_tokenizer_model("vq")
class VQTokenizer(ActionTokenizer):
    """VQ-VAE action tokenizer, one code per step (VQConfig)."""

    name = "vq"
    discrete = True

    def __init__(self, config: VQConfig, action_dim: int):
        super().__init__(config, action_dim)
        latent_dim, K = config.latent_dim, config.codebook_size
        self.encoder = build_encoder([action_dim, *config.hidden, latent_dim], config.norm,
                                     config.activation, config.output_activation,
                                     config.lipschitz)
        dec_hidden = list(config.hidden[::-1] if config.decoder_hidden is None
                          else config.decoder_hidden)
        self.decoder = mlp([latent_dim, *dec_hidden, action_dim],
                           activation=activation_class(config.activation))
        self.codebook = nn.Embedding(K, latent_dim)
        # VQ-VAE's initialisation: uniform in (-1/K, 1/K).
        nn.init.uniform_(self.codebook.weight, -1.0 / K, 1.0 / K)
        self.register_buffer("_codebook_from_data", torch.tensor(False))
        # Steps trained and codes used since the last dead-code restart.
        self.register_buffer("_steps", torch.zeros((), dtype=torch.long))
        self.register_buffer("_used", torch.zeros(K, dtype=torch.bool))

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
        cfg = self.config
        z_e = self.encoder(actions)  # (B, T, D)
        if self.training and cfg.codebook_init == "data" and not self._codebook_from_data:
            self._init_codebook_from(z_e.detach())
        z_q, codes = self.quantize(z_e)  # (B, T, D), (B, T)
        if cfg.straight_through == "vqvae":
            # VQ-VAE's z_e + sg[z_q - z_e], written sg[z_q] + (z_e - sg[z_e]): the same
            # gradient (to z_e only), and the value is exactly z_q (no rounding residue).
            z = z_q.detach() + (z_e - z_e.detach())
        elif cfg.straight_through == "codebook":
            z = z_q + (z_e - z_e.detach())  # value z_q, gradient to z_e and to the codes
        else:
            z = z_q  # gradients reach the codebook only, never the encoder
        recon = self.decoder(z)  # (B, T, A)
        losses = {
            "reconstruction": cfg.recon_weight * F.mse_loss(recon, actions),
            "codebook": cfg.codebook_weight * F.mse_loss(z_q, z_e.detach()),
            "commitment": cfg.commitment_weight * F.mse_loss(z_e, z_q.detach()),
        }
        losses.update(lipschitz_losses(self.encoder, cfg))
        if self.training and cfg.dead_code_restart:
            self._restart_dead_codes(z_e.detach(), codes)
        embeddings = z.detach() if cfg.detach_embeddings else z
        return TokenizerOutput(embeddings=embeddings, reconstruction=recon, codes=codes,
                               losses=losses, latents=z_e)

    @torch.no_grad()
    def _restart_dead_codes(self, z_e: Tensor, codes: Tensor) -> None:
        # every `dead_code_restart` steps, unused codes move to random encoder outputs
        self._used[codes.flatten()] = True
        self._steps += 1
        if int(self._steps) % self.config.dead_code_restart:
            return
        dead = (~self._used).nonzero().flatten()
        if len(dead):
            flat = z_e.reshape(-1, z_e.shape[-1])
            pick = torch.randint(len(flat), (len(dead),), device=flat.device)
            self.codebook.weight[dead] = flat[pick]
        self._used.zero_()

    def no_weight_decay(self) -> list[nn.Parameter]:
        """The codebook when `codebook_weight_decay` is off."""
        return [] if self.config.codebook_weight_decay else [self.codebook.weight]

    @torch.no_grad()
    def _init_codebook_from(self, z_e: Tensor) -> None:
        flat = z_e.reshape(-1, z_e.shape[-1])
        idx = torch.randint(len(flat), (self.codebook_size,), device=flat.device)
        noise = 1e-3 * flat.std() * torch.randn_like(self.codebook.weight)
        self.codebook.weight.copy_(flat[idx] + noise)
        self._codebook_from_data.fill_(True)
