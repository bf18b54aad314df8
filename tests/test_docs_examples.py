"""Every Python block of README.md and docs/*.md runs as written, saved as a script.

Each block runs as its own script (``python block.py``, so a process pool's workers re-import
it as they would a user's), in a folder prepared with what the examples name: a tiny finished
run at ``data/runs/<run-id>`` (and the other run paths the docs use), a tiny
``experiments/coevolve_flat.toml``, and a recording at the path the records doc reads.

A block preceded by ``<!-- no-run: REASON -->`` is not run (a fragment, or it needs a GPU, a
Dask scheduler or SLURM); the convention is documented in docs/records.md ("Trust").
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from _helpers import REPO, ariel_run, repo_env, tiny_run_toml

_BLOCK = re.compile(r"(?:<!-- no-run: (?P<reason>[^>]*) -->\n)?```python\n(?P<code>.*?)```", re.S)
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
# Run folders the examples name: each a copy of the tiny run.
RUN_PATHS = (
    "data/runs/<run-id>",
    "data/runs/<id>",
    "data/runs/coevolve_flat-20261123-101500-s1",
    "RUN",
)


def _blocks() -> list[tuple[str, str, str | None]]:
    found = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        for match in _BLOCK.finditer(text):
            line = text[: match.start("code")].count("\n") + 1
            found.append((f"{doc.name}:{line}", match.group("code"), match.group("reason")))
    return found


BLOCKS = _blocks()


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("docs")
    (root / "experiments").mkdir()
    config = root / "experiments" / "coevolve_flat.toml"
    config.write_text(tiny_run_toml("coevolve_flat", 1, record="rerun = true"))
    ariel_run(config, root / "made")
    for name in RUN_PATHS:
        shutil.copytree(root / "made", root / name)
    made = root / "made" / "recordings"
    for name, found in (
        ("b000012-i003-c005.rrd", next(p for p in made.glob("gen-*/b*.rrd"))),
        ("evaluations.rrd", next(made.glob("gen-*/evaluations.rrd"))),
    ):
        target = root / "recordings" / "gen-000003" / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(found, target)
    return root


def _fence_problems(text: str) -> list[str]:
    """Code fences that do not pair: an opening fence (```lang or ```) must be closed by a bare
    ``` before the next fence with a language and before the end of the file; else a fence
    swallows the prose (and the blocks) after it."""
    problems, opened = [], None
    for number, line in enumerate(text.splitlines(), 1):
        fence = re.match(r"\s*```(.*)$", line)
        if fence is None:
            continue
        info = fence.group(1).strip()
        if opened is None:
            opened = number
        elif info:
            problems.append(f"line {number}: ```{info} inside the block opened on line {opened}")
            opened = number
        else:
            opened = None
    if opened is not None:
        problems.append(f"line {opened}: a block that is never closed")
    return problems


def test_fence_problems_are_found() -> None:
    assert _fence_problems("```bash\nls\n```\n\ntext\n```python\nx = 1\n```\n") == []
    # a closing fence where an opening one was meant: the prose and the python block swallowed
    broken = "```bash\nls\n```\ntext\nls\n```\n\nprose\n```python\nx = 1\n```\n"
    assert _fence_problems(broken) == ["line 9: ```python inside the block opened on line 6"]
    assert _fence_problems("```\nx\n```\n```toml\n") == ["line 4: a block that is never closed"]


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_code_fences_pair(doc: Path) -> None:
    """Every ``` fence of README.md and docs/*.md opens and closes a block as meant."""
    text = doc.read_text(encoding="utf-8")
    fences = [line for line in text.splitlines() if re.match(r"\s*```", line)]
    assert len(fences) % 2 == 0, f"{doc.name}: {len(fences)} fence lines"
    assert _fence_problems(text) == [], doc.name


def test_every_block_is_found_and_most_run() -> None:
    assert len(BLOCKS) >= 20
    runnable = [name for name, _, reason in BLOCKS if reason is None]
    assert len(runnable) >= 10, runnable


@pytest.mark.parametrize(
    ("code", "reason"), [(c, r) for _, c, r in BLOCKS], ids=[n for n, _, _ in BLOCKS]
)
def test_a_docs_block_runs_as_a_script(
    workspace: Path, tmp_path: Path, code: str, reason: str | None
) -> None:
    if reason is not None:
        pytest.skip(f"marked no-run: {reason}")
    script = tmp_path / "example.py"
    script.write_text(code)
    result = subprocess.run(
        [sys.executable, str(script)],
        cwd=workspace,
        env=repo_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-3000:]
