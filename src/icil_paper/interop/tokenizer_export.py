"""A trained policy's action tokenizer as a portable folder: `icil-paper export-tokenizer`.

    icil-paper export-tokenizer runs/small/icrt+lipvq__... exported/lipvq
    icil-paper export-tokenizer --plugin ./pca.py runs/small/icrt+pca__... exported/pca

    from icil_paper.interop.tokenizer_export import export_tokenizer
    export_tokenizer("runs/small/icrt+lipvq__...", "exported/lipvq")
    from icil_paper.tokenizers import load_tokenizer
    tokenizer = load_tokenizer("exported/lipvq")
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from icil_paper.commands import Parser
from icil_paper.fileio import check_writable
from icil_paper.tokenizers.base import ActionTokenizer
from icil_paper.tokenizers.portable import TokenizerFolderError, read_config, save_tokenizer
from icil_paper.train.rundir import load_policy, policy_digest


def export_tokenizer(run_dir: str | Path, folder: str | Path) -> Path:
    """Export the tokenizer of the trained policy in `run_dir` (or a `policy.pt`) to `folder`.

    Raises TokenizerFolderError when the policy has no action tokenizer, and
    FolderNotWritableError for a `folder` this process cannot write to.
    """
    check_writable(Path(folder), f"OUT {folder}", "pass a folder this user can write to")

    policy = load_policy(run_dir)
    tokenizer = getattr(policy, "tokenizer", None)
    if not isinstance(tokenizer, ActionTokenizer):
        raise TokenizerFolderError(f"the {policy.name} policy in {run_dir} has no action "
                                   "tokenizer to export (train it with --tokenizer NAME)")
    meta = getattr(policy, "meta", {}) or {}
    spec = meta.get("spec") or {}
    source = {"run_dir": Path(run_dir).resolve().name, "run_key": meta.get("key"),
              "label": spec.get("label"), "steps": meta.get("steps"),
              "policy": policy.name, "policy_digest": policy_digest(policy)}
    return save_tokenizer(tokenizer, folder, source=source)


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="icil-paper export-tokenizer",
               description="Write the action tokenizer of a trained policy as a portable folder "
                           "(config.json, weights.safetensors; no pickle) that "
                           "icil_paper.tokenizers.load_tokenizer(OUT) loads.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder (or its policy.pt)")
    p.add_argument("out", metavar="OUT", help="folder to write (an earlier export there is "
                                              "replaced)")
    return p


def main(argv: list[str] | None = None) -> int:
    """`icil-paper export-tokenizer RUN_DIR OUT`."""
    args = build_parser().parse_args(argv)
    out = export_tokenizer(args.run_dir, args.out)
    config = read_config(out)
    facts = config["facts"]
    needs = [p["path"] if p.get("source") == "file" else p["spec"]
             for p in config.get("plugins") or []]
    also = f", plugins={needs!r}" if needs else ""
    print(f"{out}: the {facts['name']} tokenizer (action_dim {config['action_dim']}, "
          f"{facts['n_values']} weights in {facts['n_tensors']} tensors); load it with "
          f"icil_paper.tokenizers.load_tokenizer({str(out)!r}{also})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
