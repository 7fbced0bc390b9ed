"""The task lists the paper's tables run on, as names only (no simulator is imported), so that
the presets can name them without loading a suite.
"""

from __future__ import annotations

SKILL_FAMILIES = ("Pick and Place", "Open/Close Doors", "Open/Close Drawers", "Turning Levers",
                  "Twisting Knobs", "Insertion", "Pressing Buttons")
"""RoboCasa's seven skill families, in the column order of the paper's RoboCasa tables."""

ROBOCASA_FAMILIES: dict[str, tuple[str, ...]] = {
    family: tuple(f"metaworld/{t}" for t in tasks) for family, tasks in zip(SKILL_FAMILIES, (
        ("pick-place", "pick-place-wall"), ("door-open", "door-close"),
        ("drawer-open", "drawer-close"), ("faucet-open", "faucet-close"), ("dial-turn",),
        ("peg-insert-side", "coffee-push"), ("button-press", "coffee-button")), strict=True)}
"""Skill family -> the Meta-World tasks of the paper's RoboCasa tables."""

ROBOCASA_TASKS = tuple(t for tasks in ROBOCASA_FAMILIES.values() for t in tasks)
"""The 13 tasks of `ROBOCASA_FAMILIES`, in family order."""

ML45_HELD_OUT = tuple(f"metaworld/{t}" for t in (
    "bin-picking", "box-close", "hand-insert", "door-lock", "door-unlock"))
"""ML45's five test tasks (`metaworld.env_dict.ML45_V3["test"]`, in its order)."""

ML45_TRAIN = tuple(f"metaworld/{t}" for t in (
    "assembly", "basketball", "button-press-topdown", "button-press-topdown-wall",
    "button-press", "button-press-wall", "coffee-button", "coffee-pull", "coffee-push",
    "dial-turn", "disassemble", "door-close", "door-open", "drawer-close", "drawer-open",
    "faucet-open", "faucet-close", "hammer", "handle-press-side", "handle-press",
    "handle-pull-side", "handle-pull", "lever-pull", "pick-place-wall", "pick-out-of-hole",
    "push-back", "pick-place", "plate-slide", "plate-slide-side", "plate-slide-back",
    "plate-slide-back-side", "peg-insert-side", "peg-unplug-side", "soccer", "stick-push",
    "stick-pull", "push-wall", "push", "reach-wall", "reach", "shelf-place", "sweep-into",
    "sweep", "window-open", "window-close"))
"""ML45's 45 training tasks (`metaworld.env_dict.ML45_V3["train"]`, in its order)."""
