"""`mlp` and `lip-mlp`: ICRT's continuous action MLP, and the same MLP made Lipschitz.

ICRT (Fu et al. 2024) embeds each action with an MLP into the token width; the embedding is
shaped only by the policy's loss. `lip-mlp` is Table IV's ablation: the same MLP with every
linear layer a `LipschitzLinear` (Eq. 5) and the 1e-6 prod softplus(c_l) term in its losses.

    actions (B, T, A) --encoder MLP--> embeddings (B, T, D) --decoder MLP--> reconstruction

The decoder exists so that `decode` works for every tokenizer. By default it learns on
*detached* embeddings (`autoencode=False`), so the reconstruction loss trains the decoder
only and the encoder stays exactly ICRT's (trained by the policy alone). With
`autoencode=True` (stand-alone training, chapter 04) the reconstruction loss trains the
encoder too, which makes the MLP an ordinary continuous autoencoder.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch.nn.functional as F
from torch import Tensor

from icil_paper.tokenizers.base import ActionTokenizer, TokenizerOutput, mlp
from icil_paper.tokenizers.lipschitz_linear import LipschitzLinear, lipschitz_loss

DEFAULT_HIDDEN = (64, 128)


class MLPTokenizer(ActionTokenizer):
    """Continuous action embedding by an MLP (ICRT), optionally Lipschitz (`lip-mlp`).

    Args:
        action_dim, latent_dim: A and D.
        hidden: encoder hidden widths (the decoder mirrors them).
        lipschitz: make every encoder linear layer a LipschitzLinear (Eq. 5).
        autoencode: let the reconstruction loss train the encoder as well (see module doc).
        recon_weight: weight of the reconstruction loss in `losses`.
        lipschitz_weight: gamma, weight of prod softplus(c_l) (the paper: 1e-6).
    """

    name = "mlp"
    discrete = False

    def __init__(self, action_dim: int, latent_dim: int, hidden: Sequence[int] = DEFAULT_HIDDEN,
                 lipschitz: bool = False, autoencode: bool = False, recon_weight: float = 1.0,
                 lipschitz_weight: float = 1e-6):
        super().__init__(action_dim, latent_dim)
        self.lipschitz = lipschitz
        self.autoencode = autoencode
        self.recon_weight = recon_weight
        self.lipschitz_weight = lipschitz_weight
        linear = LipschitzLinear if lipschitz else None
        sizes = [action_dim, *hidden, latent_dim]
        self.encoder = mlp(sizes, linear=linear) if linear else mlp(sizes)
        self.decoder = mlp(sizes[::-1])

    def _forward(self, actions: Tensor) -> TokenizerOutput:
        z = self.encoder(actions)  # (B, T, D)
        recon = self.decoder(z if self.autoencode else z.detach())  # (B, T, A)
        losses = {"reconstruction": self.recon_weight * F.mse_loss(recon, actions)}
        if self.lipschitz:
            losses["lipschitz"] = self.lipschitz_weight * lipschitz_loss(self.encoder)
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=None, losses=losses,
                               latents=z)


class LipMLPTokenizer(MLPTokenizer):
    """`lip-mlp`: the ICRT MLP with LipschitzLinear layers (Table IV's ablation)."""

    name = "lip-mlp"

    def __init__(self, action_dim: int, latent_dim: int, **options):
        options.setdefault("lipschitz", True)
        super().__init__(action_dim, latent_dim, **options)
