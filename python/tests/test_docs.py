"""The Python blocks of the README and the guide run as they read.

Every ```python block of README.md and of docs/**/*.md runs as a standalone script from the
repository root, with the installed package. Where a ```text block follows it (only blank
lines between), that block is the script's standard output, compared line by line after
trailing spaces are dropped.
"""
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def blocks(text):
    """The fenced blocks of a Markdown text: (info, body, line, follows_previous)."""
    out = []
    lines = text.splitlines()
    i = 0
    blank_since_close = None
    while i < len(lines):
        stripped = lines[i].lstrip()
        if stripped.startswith("```"):
            info = stripped[3:].strip()
            start = i + 1
            j = start
            while j < len(lines) and not lines[j].lstrip().startswith("```"):
                j += 1
            indent = len(lines[i]) - len(stripped)
            body = [l[indent:] if l[:indent].strip() == "" else l for l in lines[start:j]]
            out.append((info, body, i + 1, blank_since_close is True))
            blank_since_close = True
            i = j + 1
            continue
        if stripped:
            blank_since_close = False
        i += 1
    return out


def documents():
    files = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
    return [f for f in files if f.exists()]


def python_blocks():
    found = []
    for doc in documents():
        bs = blocks(doc.read_text(encoding="utf-8"))
        for k, (info, body, line, _) in enumerate(bs):
            if info.split(" ")[0] != "python":
                continue
            expected = None
            if k + 1 < len(bs) and bs[k + 1][0] == "text" and bs[k + 1][3]:
                expected = bs[k + 1][1]
            found.append(pytest.param("\n".join(body), expected, id=f"{doc.relative_to(ROOT)}:{line}"))
    return found


def normalise(lines):
    out = [l.rstrip() for l in lines]
    while out and not out[-1]:
        out.pop()
    return out


def test_the_docs_have_python_blocks():
    assert python_blocks(), "README.md and docs/ show no ```python block"


@pytest.mark.parametrize("code,expected", python_blocks())
def test_a_python_block_runs_and_prints_what_it_shows(code, expected):
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"the block failed:\n{code}\n--- stderr\n{run.stderr}"
    if expected is not None:
        assert normalise(run.stdout.splitlines()) == normalise(expected), (
            f"the output shown is not what the block prints:\n--- shown\n"
            + "\n".join(expected)
            + "\n--- printed\n"
            + run.stdout
        )
