"""The README and docs/ as a user's guide and a reference of the code as it
is: the README short enough to read, and neither it nor docs/*.md dated or
numbered by the work history (issue numbers, dates, branch names and commit
hashes belong in bench/results/ and CHANGES.md)."""
import glob
import os
import re

import pytest

from harness import REPO

README = os.path.join(REPO, "README.md")
DOCS = sorted(glob.glob(os.path.join(REPO, "docs", "*.md")))

# What the work history leaves in text: "issue 12", an ISO date, a branch of
# the project's history, a commit hash (7-40 hex digits with a digit and a
# letter, standing alone: not part of 0x... constants or longer words).
HISTORY = [
    ("issue number", re.compile(r"\bissues? #?[0-9]+", re.I)),
    ("date", re.compile(r"\b20[0-9]{2}-[01][0-9]-[0-3][0-9]\b")),
    ("branch name", re.compile(r"\b(best-pass|exp-best|issue[0-9]+-[a-z]+|wip/[a-z0-9-]+)\b")),
    ("commit hash", re.compile(r"(?<![0-9A-Za-z_.])(?=[0-9a-f]*[0-9])(?=[0-9a-f]*[a-f])"
                               r"[0-9a-f]{7,40}(?![0-9A-Za-z_])")),
]


def history_marks(path):
    found = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            for what, pattern in HISTORY:
                for m in pattern.finditer(line):
                    found.append("%s:%d: %s %r" % (os.path.relpath(path, REPO), number, what,
                                                    m.group(0)))
    return found


def test_the_history_patterns_catch_what_they_are_for(tmp_path):
    sample = tmp_path / "sample.md"
    sample.write_text("issue 12 on 2026-11-27 in exp-best, commit f6d1c48\n"
                      "0x1p-48, 0xdeadbeef1, sha a1b2c3 and the word 'defaced' stay\n")
    kinds = sorted(m.split(": ")[1].split(" '")[0] for m in history_marks(str(sample)))
    assert kinds == ["branch name", "commit hash", "date", "issue number"]


@pytest.mark.parametrize("path", [README] + DOCS, ids=lambda p: os.path.relpath(p, REPO))
def test_no_work_history_in_the_docs(path):
    assert history_marks(path) == []


def test_the_readme_is_a_short_guide():
    with open(README, encoding="utf-8") as f:
        lines = f.read().split("\n")
    assert len(lines) <= 250
    long_lines = [i + 1 for i, line in enumerate(lines) if len(line) > 200]
    assert long_lines == []
    text = "\n".join(lines)
    # It starts with the two commands a fresh machine runs.
    first_block = text.split("```")[1]
    assert "make demo" in first_block and "make test" in first_block


def test_the_readme_links_to_files_that_exist():
    with open(README, encoding="utf-8") as f:
        text = f.read()
    targets = re.findall(r"\]\(([^)#\s]+)", text)
    assert targets, "no links found"
    missing = [t for t in targets if not os.path.exists(os.path.join(REPO, t))]
    assert missing == []
