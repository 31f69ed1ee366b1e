"""The rules and the history live in the repository: every house rule the code cites is defined in
CONTRIBUTING.md, and CHANGELOG.md names the current version of every file format."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Where the project's Python lives (not build output or virtual environments).
FOLDERS = ("stimuli", "experiment", "analysis", "tests", "benchmarks")

#: A rule citation in a comment or docstring: the letter H and one or two digits, as a word.
_CITATION = re.compile(r"\bH([0-9]{1,2})\b")


def _cited_rules() -> dict[int, list[str]]:
    cited: dict[int, list[str]] = {}
    paths = [p for folder in FOLDERS for p in sorted((ROOT / folder).rglob("*.py"))]
    for path in paths:
        rel = path.relative_to(ROOT)
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in _CITATION.finditer(line):
                cited.setdefault(int(m.group(1)), []).append(f"{rel}:{lineno}")
    return cited


def _defined_rules() -> set[int]:
    text = (ROOT / "CONTRIBUTING.md").read_text(encoding="utf-8")
    return {int(m.group(1)) for m in re.finditer(r"^\*\*H([0-9]{1,2})\. ", text, re.M)}


def test_every_cited_house_rule_is_defined_in_contributing() -> None:
    cited = _cited_rules()
    assert cited, "no rule citation found: the pattern or the walk is broken"
    missing = {n: where for n, where in cited.items() if n not in _defined_rules()}
    assert not missing, f"rules cited but not defined in CONTRIBUTING.md: {missing}"


def test_house_rules_are_numbered_once_and_in_order() -> None:
    text = (ROOT / "CONTRIBUTING.md").read_text(encoding="utf-8")
    numbers = [int(m.group(1)) for m in re.finditer(r"^\*\*H([0-9]{1,2})\. ", text, re.M)]
    assert numbers == list(range(1, len(numbers) + 1))


def test_changelog_names_every_current_format_version() -> None:
    from experiment.log.schema import MIGRATIONS, latest_version
    from experiment.viewer.events import SCHEMA_VERSION
    from stimuli.stimset.provenance import SET_FORMAT_VERSION

    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [Unreleased]" in text
    schema = text.split("### Trial-log schema", 2)
    assert len(schema) == 3, "CHANGELOG.md needs a trial-log schema section per version"
    for version, name, _sql in MIGRATIONS:
        assert f"**{version} — " in schema[2], f"schema migration {version} ({name}) missing"
    assert latest_version() == MIGRATIONS[-1][0]
    assert f"(latest: {latest_version()})" in schema[1]
    assert f"(latest: {SET_FORMAT_VERSION})" in text
    assert f"- **{SET_FORMAT_VERSION}** (" in text
    assert f"### Viewer event log\n- **{SCHEMA_VERSION}** (" in text


def test_ci_runs_ruff_before_the_tests() -> None:
    """CI runs the configured linter and formatter check, from the dev extra, before pytest."""
    import tomllib

    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert "ruff check ." in lines and "ruff format --check ." in lines
    pytest_at = lines.index("python -m pytest")
    assert (
        lines.index("ruff check .") < pytest_at and lines.index("ruff format --check .") < pytest_at
    )
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert any(d.startswith("ruff") for d in config["project"]["optional-dependencies"]["dev"])
    lint = config["tool"]["ruff"]["lint"]
    assert "D" in lint["select"] and lint["pydocstyle"]["convention"] == "numpy"
