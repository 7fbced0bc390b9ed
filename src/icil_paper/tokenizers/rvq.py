"""`rvq` and `liprvq`: residual vector quantization, VQ-BeT's action tokenizer (Lee et al.
2024; the quantizer of SoundStream, Zeghidour et al. 2021), with and without Eq. 4.

    actions (B, T, A) --encoder--> z_e (B, T, D)
        level 1: k_1 = nearest code of codebook 1 to r_0 = z_e,        r_1 = r_0 - e_1[k_1]
        level 2: k_2 = nearest code of codebook 2 to r_1,              r_2 = r_1 - e_2[k_2]
        ...      (Q levels, K codes each)
        z_q = e_1[k_1] + ... + e_Q[k_Q] --> embeddings (B, T, D) --decoder--> x_hat

The quantizer is `vector_quantize_pytorch.ResidualVQ` with its defaults (EMA codebooks, the
rotation trick). Loss: L_rec + beta * the per-level commitment loss, plus Eq. 5's Lipschitz
term for `liprvq`, whose encoder layers are all `LipschitzLinear`.

Deviations from VQ-BeT: one action per step is quantized (VQ-BeT quantizes a chunk); no
offset head.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import (
    ActionTokenizer,
    TokenizerOutput,
    build_encoder,
    evaluating,
    lipschitz_losses,
)
from icil_paper.tokenizers.configs import RVQConfig, register_tokenizer_model


@register_tokenizer_model("rvq")
class RVQTokenizer(ActionTokenizer):
    """Residual VQ of one action per step (RVQConfig; `liprvq`: LipRVQConfig)."""

    name = "rvq"
    discrete = True

    def __init__(self, config: RVQConfig, action_dim: int):
        super().__init__(config, action_dim)
        from vector_quantize_pytorch import ResidualVQ

        self.num_quantizers = int(config.num_quantizers)
        self.level_size = int(config.codebook_size)
        latent_dim = config.latent_dim
        self.encoder = build_encoder([action_dim, *config.hidden, latent_dim], config.norm,
                                     lipschitz=config.lipschitz)
        # commitment weight 1 here: the sum over levels is weighted below
        self.quantizer = ResidualVQ(dim=latent_dim, num_quantizers=self.num_quantizers,
                                    codebook_size=self.level_size, commitment_weight=1.0)
        self.decoder = mlp([latent_dim, *config.hidden[::-1], action_dim])
        # Token id of code k at level l is l * K + k.
        self.register_buffer("offsets", torch.arange(self.num_quantizers) * self.level_size,
                             persistent=False)

    @property
    def codebook_size(self) -> int:
        """Q * K stored code vectors (a step uses one per level)."""
        return self.num_quantizers * self.level_size

    def quantize(self, z_e: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """z_e (B, T, D) -> (z_q (B, T, D), codes (B, T, Q), commitment loss per level (Q,);
        zeros outside training)."""
        z_q, codes, level_losses = self.quantizer(z_e)
        return z_q, codes.long(), level_losses.reshape(-1)

    def level_errors(self, actions: Tensor) -> list[float]:
        """Mean squared quantization error ||z_e - (e_1[k_1] + ... + e_l[k_l])||^2 after each
        level l = 1 .. Q, for actions (B, T, A) (eval mode: no codebook update)."""
        with evaluating(self):
            z_e = self.encoder(self.check_actions(actions))
            _, _, _, per_level = self.quantizer(z_e, return_all_codes=True)  # (Q, B, T, D)
            partial = per_level.cumsum(dim=0)
            return [float(((z_e - partial[l]) ** 2).mean()) for l in range(len(partial))]

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z_e = self.encoder(actions)  # (B, T, D)
        z_q, codes, level_losses = self.quantize(z_e)  # (B, T, D), (B, T, Q), (Q,)
        recon = self.decoder(z_q)  # (B, T, A)
        losses = {"reconstruction": self.config.recon_weight * F.mse_loss(recon, actions)}
        if self.training:
            losses["commitment"] = self.config.commitment_weight * level_losses.sum()
        losses.update(lipschitz_losses(self.encoder, self.config))
        return TokenizerOutput(embeddings=z_q, reconstruction=recon, codes=codes, losses=losses,
                               latents=z_e)

    def vocabulary_ids(self, codes: Tensor) -> Tensor:
        """Codes (B, T, Q) as ids in [0, Q * K) (level l's code k is l * K + k), flattened."""
        return (codes + self.offsets).flatten()

    def codes_by_level(self, codes: Tensor) -> list[Tensor]:
        """Codes (..., Q) -> each level's codes in [0, K), flat."""
        return [codes[..., level].flatten() for level in range(self.num_quantizers)]


@register_tokenizer_model("liprvq")
class LipRVQTokenizer(RVQTokenizer):
    """`liprvq`: residual VQ whose encoder is Lipschitz-constrained by Eq. 4 (as LipVQ-VAE's)."""

    name = "liprvq"
