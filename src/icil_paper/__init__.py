"""icil_paper: the library behind the companion to "Action Tokenizer Matters in
In-Context Imitation Learning" (LipVQ-VAE).

Submodules are imported lazily so that `import icil_paper` stays cheap. Start from
`icil_paper.config` (presets and configs), `icil_paper.tokenizers` (`make_tokenizer`),
`icil_paper.policies`, `icil_paper.sim` (`make_env`), `icil_paper.data`, `icil_paper.train`,
`icil_paper.eval`, `icil_paper.results` (the store) and `icil_paper.paper` (one module per
result of the paper). The tools that run the project live in `tools/`, not in the library.
"""

__version__ = "0.1.0"
