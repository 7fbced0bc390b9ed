"""`.ci/find-python312` (what `make lerobot-setup` builds its environment from): the first
candidate that runs as Python 3.12 wins, a pyenv shim of an unselected version is passed over,
and with none it says in one line what to install or pass."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from icil_paper.setup.provenance import REPO_ROOT

FINDER = REPO_ROOT / ".ci" / "find-python312"
SYSTEM = Path("/usr/bin/python3.12")  # the last candidate, not under the test's control
SHIM = """#!/bin/sh
echo "pyenv: python3.12: command not found" >&2
exit 127
"""


def fake_python(path: Path, version: str) -> Path:
    """An executable that answers the finder's version probe as Python `version` would."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"#!/bin/sh\necho {version}\n")
    path.chmod(0o755)
    return path


def tool(bin_dir: Path, name: str, script: str) -> None:
    (bin_dir / name).write_text("#!/bin/sh\n" + script)
    (bin_dir / name).chmod(0o755)


def find(bin_dir: Path, python312: str | None = None) -> subprocess.CompletedProcess:
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(bin_dir)}
    if python312 is not None:
        env["PYTHON312"] = python312
    return subprocess.run(["bash", str(FINDER)], env=env, capture_output=True, text=True,
                          timeout=60)


def system_runs() -> bool:
    try:
        return subprocess.run([str(SYSTEM), "--version"], capture_output=True).returncode == 0
    except OSError:
        return False


@pytest.fixture
def bin_dir(tmp_path):
    path = tmp_path / "bin"
    path.mkdir()
    tool(path, "python3.12", SHIM)  # the machine's situation: a shim that does not run
    return path


def test_a_shim_of_an_unselected_version_gives_way_to_pyenvs_312(bin_dir, tmp_path):
    real = fake_python(tmp_path / "pyenv/versions/3.12.4/bin/python3.12", "3.12")
    tool(bin_dir, "pyenv", f'[ "$1 $2" = "prefix 3.12" ] && echo {real.parent.parent} && exit 0\n'
                           f'[ "$1" = root ] && echo {tmp_path / "pyenv"} && exit 0\nexit 1\n')
    done = find(bin_dir)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(real)


def test_pyenv_without_prefix_matching_falls_back_to_its_newest_312(bin_dir, tmp_path):
    for v in ("3.12.2", "3.12.10"):
        fake_python(tmp_path / f"pyenv/versions/{v}/bin/python3.12", "3.12")
    tool(bin_dir, "pyenv", f'[ "$1" = root ] && echo {tmp_path / "pyenv"} && exit 0\n'
                           'echo "pyenv: version 3.12 not installed" >&2; exit 1\n')
    done = find(bin_dir)
    assert done.stdout.strip() == str(tmp_path / "pyenv/versions/3.12.10/bin/python3.12")


def test_uv_is_asked_when_pyenv_has_none(bin_dir, tmp_path):
    real = fake_python(tmp_path / "uv/cpython-3.12/bin/python3.12", "3.12")
    tool(bin_dir, "uv", f'[ "$*" = "python find 3.12" ] && echo {real} && exit 0\nexit 2\n')
    assert find(bin_dir).stdout.strip() == str(real)


def test_a_working_python312_on_path_comes_first(bin_dir, tmp_path):
    fake_python(bin_dir / "python3.12", "3.12")
    other = fake_python(tmp_path / "uv/bin/python3.12", "3.12")
    tool(bin_dir, "uv", f"echo {other}\n")
    assert find(bin_dir).stdout.strip() == str(bin_dir / "python3.12")


def test_a_candidate_of_another_version_is_not_taken(bin_dir, tmp_path):
    fake_python(bin_dir / "python3.12", "3.11")  # a misnamed link
    done = find(bin_dir)
    if system_runs():
        assert done.stdout.strip() == str(SYSTEM)
    else:
        assert done.returncode == 1 and done.stdout == ""


@pytest.mark.skipif(system_runs(), reason=f"{SYSTEM} runs here, so something is always found")
def test_none_found_says_what_to_install_or_pass_in_one_line(bin_dir):
    done = find(bin_dir)
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.count("\n") == 1
    assert "install one" in done.stderr and "PYTHON312=/path/to/python3.12" in done.stderr
    assert str(bin_dir / "python3.12") in done.stderr  # it names what it tried


def test_an_explicit_python312_is_used_or_named(bin_dir, tmp_path):
    chosen = fake_python(tmp_path / "mine/python", "3.12")
    assert find(bin_dir, str(chosen)).stdout.strip() == str(chosen)
    fake_python(tmp_path / "pyenv/versions/3.12.1/bin/python3.12", "3.12")
    tool(bin_dir, "pyenv", f'[ "$1" = root ] && echo {tmp_path / "pyenv"}\n')
    done = find(bin_dir, str(bin_dir / "python3.12"))  # the shim, chosen: not replaced
    assert done.returncode == 1 and done.stdout == ""
    assert f"PYTHON312={bin_dir / 'python3.12'} does not run" in done.stderr


@pytest.mark.skipif(system_runs(), reason=f"{SYSTEM} runs here, so something is always found")
def test_make_lerobot_setup_names_the_fix_instead_of_running_a_shim(bin_dir, tmp_path):
    venv = tmp_path / "venv-lerobot"
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(tmp_path)}
    done = subprocess.run(["make", "--no-print-directory", "-C", str(REPO_ROOT), "lerobot-setup",
                           f"LEROBOT_VENV={venv}"], env=env, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode != 0 and not venv.exists()
    assert "lerobot-setup: no Python 3.12 runs here" in done.stderr
    assert "command not found" not in done.stderr  # the shim's own failure (exit 127) is gone


@pytest.mark.parametrize("folder", ["it's mine", 'say "3.12"', "a b; echo hi"])
def test_make_lerobot_setup_takes_any_path_in_python312(bin_dir, tmp_path, folder):
    """The path reaches the finder as it is: quotes, spaces and shell words in it are not
    pasted into the recipe's shell line."""
    chosen = fake_python(tmp_path / folder / "python", "3.12")
    venv = tmp_path / "venv-lerobot"
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(tmp_path)}
    done = subprocess.run(["make", "--no-print-directory", "-C", str(REPO_ROOT), "lerobot-setup",
                           f"LEROBOT_VENV={venv}", f"PYTHON312={chosen}"], env=env,
                          capture_output=True, text=True, timeout=60)
    # the fake interpreter makes no environment, so pip is missing after it: only the
    # finder's choice is checked here
    assert f"lerobot-setup: {venv} from {chosen}\n" in done.stdout, done.stderr
