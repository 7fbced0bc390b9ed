"""`lfq`: lookup-free quantization (MAGVIT-v2, Yu et al. 2024), the paper's "LFQ-VAE".

    actions (B, T, A) --encoder--> z_e (B, T, b), b = log2(K) bits
        --sign per dimension--> q in {-1, +1}^b, code = the bit pattern (an int in [0, K))
        --straight-through--> (project to D if b != D) --> embeddings (B, T, D) --decoder--> x_hat

Losses: L_rec + entropy_weight * (mean per-sample entropy - gamma * batch codebook entropy)
+ commitment_weight * ||z_e - sg[q]||^2. The entropy term makes each step's code confident
while spreading the batch over the whole implicit codebook of 2^b codes.

The quantizer is `vector_quantize_pytorch.LFQ`; in eval mode it returns the hard codes and
no losses. The +-1 code (b = log2(K) bits, usually fewer than D) is mapped to D by a learned
linear projection, which both the policy and the decoder read.

(The official code's "LFQ-VAE" only L2-normalizes the encoder output; this file implements
the method the paper cites.)
"""

from __future__ import annotations

import math

import torch.nn.functional as F
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput
from icil_paper.tokenizers.configs import LFQConfig, register_tokenizer_model


@register_tokenizer_model("lfq")
class LFQTokenizer(ActionTokenizer):
    """Lookup-free quantization of one action per step (LFQConfig)."""

    name = "lfq"
    discrete = True

    def __init__(self, config: LFQConfig, action_dim: int):
        super().__init__(config, action_dim)
        from vector_quantize_pytorch import LFQ

        codebook_size, latent_dim, hidden = config.codebook_size, config.latent_dim, config.hidden
        bits = self.bits = int(round(math.log2(codebook_size)))  # a power of two (config checks)
        self.encoder = mlp([action_dim, *hidden, bits])
        # Weights 1.0 here: the breakdown is weighted below, so `losses` shows each term.
        self.quantizer = LFQ(dim=bits, codebook_size=codebook_size, entropy_loss_weight=1.0,
                             commitment_loss_weight=1.0, diversity_gamma=config.diversity_gamma)
        self.project = nn.Identity() if bits == latent_dim else nn.Linear(bits, latent_dim)
        self.decoder = mlp([latent_dim, *hidden[::-1], action_dim])

    @property
    def codebook_size(self) -> int:
        return 2**self.bits

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z_e = self.encoder(actions)  # (B, T, bits)
        (q, codes, _), breakdown = self.quantizer(z_e, return_loss_breakdown=True)
        z = self.project(q)  # (B, T, D)
        recon = self.decoder(z)
        cfg = self.config
        losses = {"reconstruction": cfg.recon_weight * F.mse_loss(recon, actions)}
        if self.training:
            entropy = breakdown.per_sample_entropy - cfg.diversity_gamma * breakdown.batch_entropy
            losses["entropy"] = cfg.entropy_weight * entropy
            losses["commitment"] = cfg.commitment_weight * breakdown.commitment
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=codes.long(),
                               losses=losses, latents=z_e)
