"""`mlp` and `lip-mlp`: ICRT's continuous action MLP, and the same MLP made Lipschitz.

ICRT (Fu et al. 2024) embeds each action with an MLP, shaped only by the policy's loss.
`lip-mlp` is Table IV's ablation: every linear layer a `LipschitzLinear` (Eq. 4), plus Eq. 5's
Lipschitz term.

    actions (B, T, A) --encoder MLP--> embeddings (B, T, D) --decoder MLP--> reconstruction

The decoder learns on detached embeddings, so the encoder stays ICRT's; `autoencode=True`
(stand-alone training) lets the reconstruction loss train the encoder too.
"""

from __future__ import annotations

import torch.nn.functional as F
from torch import Tensor

from icil_paper.layers import mlp
from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput, build_encoder
from icil_paper.tokenizers.configs import LipMLPConfig, MLPConfig, register_tokenizer_model
from icil_paper.tokenizers.lipschitz_linear import lipschitz_loss


@register_tokenizer_model("mlp")
class MLPTokenizer(ActionTokenizer):
    """Continuous action embedding by an MLP (ICRT); `lip-mlp` with a LipMLPConfig."""

    name = "mlp"
    discrete = False

    def __init__(self, config: MLPConfig, action_dim: int):
        super().__init__(config, action_dim)
        self.lipschitz = isinstance(config, LipMLPConfig)
        sizes = [action_dim, *config.hidden, config.latent_dim]
        if self.lipschitz:
            self.encoder = build_encoder(sizes, "lipschitz", lipschitz=config.lipschitz)
        else:
            self.encoder = mlp(sizes)
        self.decoder = mlp(sizes[::-1])

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z = self.encoder(actions)  # (B, T, D)
        cfg = self.config
        recon = self.decoder(z if cfg.autoencode else z.detach())  # (B, T, A)
        losses = {"reconstruction": cfg.recon_weight * F.mse_loss(recon, actions)}
        if self.lipschitz and cfg.lipschitz.weight:
            losses["lipschitz"] = cfg.lipschitz.weight * lipschitz_loss(self.encoder)
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=None, losses=losses,
                               latents=z)


@register_tokenizer_model("lip-mlp")
class LipMLPTokenizer(MLPTokenizer):
    """`lip-mlp`: the ICRT MLP with LipschitzLinear layers (Table IV's ablation)."""

    name = "lip-mlp"
