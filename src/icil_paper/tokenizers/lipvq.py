"""`lipvq`: LipVQ-VAE (Sec. III-B), the paper's tokenizer.

As the paper writes it (`variant="paper"`, the default):

    encoder  LipschitzLinear(A, 64) - ReLU - LipschitzLinear(64, 128) - ReLU - LipschitzLinear(128, D)
             (Eq. 5 on every layer, one trainable bound c_l per layer, Liu et al.'s init)
    quantize nearest codebook entry in L2, K = 1024, straight-through gradients
    decoder  Linear(D, 128) - ReLU - Linear(128, 64) - ReLU - Linear(64, A)
    loss     L_rec + 1.0 L_codebook + 0.25 L_commit + 1e-6 prod_l softplus(c_l)

The encoder is then Lipschitz in the infinity norm with constant at most
prod_l softplus(c_l): neighbouring actions map to neighbouring latents, which is what makes
the latent trajectory of a smooth action trajectory smooth.

The official code differs (`variant="official"`, so that the difference can be measured):

    encoder  Linear(A, 64) - GELU - Linear(64, 128) - GELU - LipschitzLinear(128, D) - sigmoid
             (only the last layer normalized, one bound per output row, c initialised to
             ones, randn weights)
    quantize nearest codebook entry in L2, K = 1024, no straight-through estimator (the
             encoder learns from the commitment loss only)
    decoder  Linear(D, 64) - GELU - Linear(64, 128) - GELU - Linear(128, A)
    loss     L_rec + 0.25 L_codebook + 0.25 L_commit (no Lipschitz term)
    policy   receives the quantized latent detached
"""

from __future__ import annotations

from icil_paper.tokenizers.vq import VQTokenizer

VARIANTS = ("paper", "official")

OFFICIAL_OPTIONS = dict(
    norm="lipschitz-last",
    activation="gelu",
    output_activation="sigmoid",
    straight_through=False,
    detach_embeddings=True,
    codebook_weight=0.25,
    commitment_weight=0.25,
    lipschitz_weight=0.0,
    hidden=(64, 128),
    decoder_hidden=(64, 128),
    lipschitz_options=dict(per_row=True, c_init=1.0, weight_init="randn"),
)


class LipVQTokenizer(VQTokenizer):
    """LipVQ-VAE: a VQ-VAE whose encoder is Lipschitz-constrained (see the module docstring).

    Args:
        action_dim, latent_dim: A and D.
        codebook_size: K (the paper: 1024).
        variant: "paper" (default) or "official".
        **options: any VQTokenizer option, overriding the variant's defaults.
    """

    name = "lipvq"

    def __init__(self, action_dim: int, latent_dim: int, codebook_size: int = 1024,
                 variant: str = "paper", **options):
        if variant not in VARIANTS:
            raise ValueError(f"unknown lipvq variant {variant!r}; valid: {', '.join(VARIANTS)}")
        defaults = dict(norm="lipschitz") if variant == "paper" else dict(OFFICIAL_OPTIONS)
        defaults.update(options)
        super().__init__(action_dim, latent_dim, codebook_size=codebook_size, **defaults)
        self.variant = variant
