"""`lipvq`: LipVQ-VAE (Sec. III-B), the paper's tokenizer.

As the paper writes it (`LipVQConfig()`, the default):

    encoder  LipschitzLinear(A, 64) - ReLU - LipschitzLinear(64, 128) - ReLU - LipschitzLinear(128, D)
             (Eq. 4 on every layer, one trainable bound c_l per layer, Liu et al.'s init)
    quantize nearest codebook entry in L2, K = 1024, VQ-VAE's straight-through gradient
    decoder  Linear(D, 128) - ReLU - Linear(128, 64) - ReLU - Linear(64, A)
    loss     L_rec + 1.0 L_codebook + 0.25 L_commit + 1e-6 prod_l softplus(c_l)   (Eq. 5)

The encoder is then Lipschitz in the infinity norm with constant at most
prod_l softplus(c_l) (Eq. 3): neighbouring actions map to neighbouring latents, which is what
makes the latent trajectory of a smooth action trajectory smooth.

The official code differs (`configs.lipvq_official()`, so that the difference can be measured):

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

from icil_paper.tokenizers.configs import register_tokenizer_model
from icil_paper.tokenizers.vq import VQTokenizer


@register_tokenizer_model("lipvq")
class LipVQTokenizer(VQTokenizer):
    """LipVQ-VAE: a VQ-VAE whose encoder is Lipschitz-constrained (see the module docstring)."""

    name = "lipvq"
