"""The documentation stays true to the repository: links resolve, the README stays short, its commands still parse.

Fast and without flights. Checked:

* every relative link of README.md, CONTRIBUTING.md and docs/*.md names a file or folder that exists, and its
  ``#anchor``, if any, matches a heading of the target file under GitHub's anchor rules (lowercase, spaces to
  ``-``, punctuation dropped except ``-`` and ``_``, a repeated heading numbered ``-1``, ``-2``...);
* README.md is at most :data:`README_MAX_LINES` lines;
* every ```bash / ```sh / ```console block of README.md passes ``bash -n``; each ``geofence-testbed ...``
  command in it parses with the CLI's own argparse parser (:func:`scenarios.app.cli.build_parser`), so it names
  a subcommand and options that exist; and each argument that looks like a repository path
  (``scenarios/....yaml``) exists;
* every ```yaml block of README.md that is a whole scenario (it names an ``aircraft``) passes
  ``geofence-testbed validate``;
* every ``docs/campaigns.md#anchor`` named in a .py file of the packages (a docstring's or comment's
  ``(case history: ...)`` pointer) matches a heading of docs/campaigns.md.

The checkers are tested on small documents of their own first, so a checker that cannot fail fails here.
"""

from __future__ import annotations

import contextlib
import glob
import io
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from scenarios.app.cli import build_parser
from scenarios.app.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
README_MAX_LINES = 300
DOC_FILES = [README, ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").glob("*.md"))]

FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>```+|~~~+)(?P<info>[^\n]*)$")
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
CODE_SPAN = re.compile(r"(`+)(?:.|\n)*?(?<!`)\1(?!`)")
SHELL_LANGUAGES = {"bash", "sh", "shell", "console"}
COMMAND_SEPARATORS = {"&&", "||", ";", "|", "&", "(", ")", ";;"}
OUTPUT_OPTIONS = {"--out", "-o"}
CAMPAIGNS = ROOT / "docs" / "campaigns.md"
CODE_PACKAGES = ("geofence", "aircraft", "wind", "analysis", "scenarios")
CAMPAIGNS_ANCHOR = re.compile(r"docs/campaigns\.md#([\w\-]+)")
"""Options whose value is a path the command writes: it need not exist yet."""


# ---------------------------------------------------------------------------------------------- markdown reading


def is_closing(line: str, fence: str) -> bool:
    """``line`` closes a block opened by ``fence`` (the same character, at least as many, nothing else)."""
    stripped = line.strip()
    return stripped.startswith(fence) and not stripped.strip(fence[0])


def blocks(text: str) -> list[tuple[str, str]]:
    """The fenced code blocks of a markdown text: (info string's first word, body)."""
    found: list[tuple[str, str]] = []
    fence: str | None = None
    language, body = "", []
    for line in text.split("\n"):
        m = FENCE.match(line)
        if fence is None:
            if m:
                fence, info, body = m.group("fence"), m.group("info").strip(), []
                language = info.split()[0].lower() if info else ""
        elif is_closing(line, fence):
            found.append((language, "\n".join(body)))
            fence = None
        else:
            body.append(line)
    return found


def without_fences(text: str) -> str:
    """A markdown text with its fenced code blocks blanked (a ``# comment`` there is no heading, a link no link)."""
    out: list[str] = []
    fence: str | None = None
    for line in text.split("\n"):
        m = FENCE.match(line)
        if fence is None and m:
            fence = m.group("fence")
        elif fence is not None:
            if is_closing(line, fence):
                fence = None
        else:
            out.append(line)
            continue
        out.append("")
    return "\n".join(out)


def prose(text: str) -> str:
    """A markdown text without its fenced code blocks and code spans (links there are not links)."""
    return CODE_SPAN.sub("", without_fences(text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: markup and punctuation dropped (``-`` and ``_`` kept), lowercase, spaces to ``-``."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link in a heading: its text
    text = re.sub(r"<[^>]+>", "", text)  # inline HTML
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)  # \w is unicode-aware: letters and digits of any script, and '_'
    return text.replace(" ", "-")


def anchors(text: str) -> set[str]:
    """Every heading anchor of a markdown text, repeated headings numbered as GitHub does (``x``, ``x-1``, ...)."""
    seen: dict[str, int] = {}
    out: set[str] = set()
    for line in without_fences(text).split("\n"):
        m = HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def broken_links(doc: Path) -> list[str]:
    """One line per relative link of ``doc`` whose file is missing or whose anchor matches no heading there."""
    problems: list[str] = []
    text = doc.read_text(encoding="utf-8")
    for target in LINK.findall(prose(text)):
        if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target):  # http:, https:, mailto: ...
            continue
        path_part, _, anchor = target.partition("#")
        dest = doc if not path_part else (doc.parent / path_part)
        if not dest.exists():
            problems.append(f"{doc.name}: ({target}): no such file {dest}")
            continue
        if anchor:
            if dest.is_dir() or dest.suffix.lower() != ".md":
                problems.append(f"{doc.name}: ({target}): an anchor into a file that is not markdown")
            elif anchor not in anchors(dest.read_text(encoding="utf-8")):
                problems.append(f"{doc.name}: ({target}): no heading '#{anchor}' in {dest.name}")
    return problems


def campaign_anchor_problems(py_files: list[Path], heading_anchors: set[str]) -> list[str]:
    """One line per ``docs/campaigns.md#anchor`` named in ``py_files`` that is not in ``heading_anchors``."""
    problems: list[str] = []
    for path in py_files:
        for n, line in enumerate(path.read_text(encoding="utf-8").split("\n"), start=1):
            for anchor in CAMPAIGNS_ANCHOR.findall(line):
                if anchor not in heading_anchors:
                    problems.append(f"{path}:{n}: no heading '#{anchor}' in docs/campaigns.md")
    return problems


def code_files() -> list[Path]:
    return sorted(p for package in CODE_PACKAGES for p in (ROOT / package).rglob("*.py"))


# ---------------------------------------------------------------------------------------------- shell commands


def shell_script(language: str, body: str) -> str:
    """The script of a shell block: a ```console block's ``$ `` lines (its output dropped), else the whole body."""
    if language != "console":
        return body
    return "\n".join(line[2:] for line in body.split("\n") if line.startswith("$ "))


def commands(script: str) -> list[list[str]]:
    """The simple commands of a shell script, each as its words (comments, operators and ``VAR=value`` dropped)."""
    joined = re.sub(r"\\\n", " ", script)
    out: list[list[str]] = []
    for line in joined.split("\n"):
        lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
        lexer.whitespace_split = True
        current: list[str] = []
        for token in lexer:
            if token in COMMAND_SEPARATORS:
                if current:
                    out.append(current)
                current = []
            elif current or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*=", token):
                current.append(token)
        if current:
            out.append(current)
    return out


def top_level_entries(root: Path) -> set[str]:
    return {p.name for p in root.iterdir() if not p.name.startswith(".") or p.name == ".ci"}


def missing_repo_paths(words: list[str], root: Path) -> list[str]:
    """The words that look like paths inside the repository (first part a top-level entry of it) and name nothing."""
    top = top_level_entries(root)
    missing: list[str] = []
    previous = ""
    for word in words:
        value = word.split("=", 1)[1] if word.startswith("--") and "=" in word else word
        is_output = previous in OUTPUT_OPTIONS or (word.startswith("--") and word.split("=", 1)[0] in OUTPUT_OPTIONS)
        previous = word
        if is_output or "/" not in value or value.startswith(("-", "/", "~", "$")):
            continue
        first = value.split("/", 1)[0]
        if first not in top:
            continue
        if any(c in value for c in "*?["):
            if not glob.glob(str(root / value)):
                missing.append(value)
        elif not (root / value).exists():
            missing.append(value)
    return missing


def cli_parse_error(args: list[str]) -> str | None:
    """``None`` when the CLI's argparse parser accepts ``args`` (``--help`` and ``--version`` included), else its message."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            build_parser().parse_args(args)
        except SystemExit as exc:
            if exc.code not in (0, None):
                return err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit {exc.code}"
    return None


def command_problems(script: str, root: Path) -> list[str]:
    """One line per ``geofence-testbed`` (or ``python -m scenarios.app.cli``) command that does not parse, and per
    repository path in any command that does not exist."""
    problems: list[str] = []
    for words in commands(script):
        shown = " ".join(words)
        for path in missing_repo_paths(words, root):
            problems.append(f"{shown}: no such path in the repository: {path}")
        args: list[str] | None = None
        if Path(words[0]).name == "geofence-testbed":
            args = words[1:]
        elif Path(words[0]).name.startswith("python") and words[1:3] == ["-m", "scenarios.app.cli"]:
            args = words[3:]
        if args is not None:
            message = cli_parse_error(args)
            if message:
                problems.append(f"{shown}: {message}")
    return problems


def bash_syntax_error(script: str) -> str | None:
    result = subprocess.run(["bash", "-n"], input=script, capture_output=True, text=True, timeout=30)
    return None if result.returncode == 0 else result.stderr.strip() or f"bash -n exit {result.returncode}"


def readme_shell_blocks() -> list[tuple[int, str]]:
    found = [(lang, body) for lang, body in blocks(README.read_text(encoding="utf-8")) if lang in SHELL_LANGUAGES]
    return [(i, shell_script(lang, body)) for i, (lang, body) in enumerate(found)]


# ---------------------------------------------------------------------------------------------- the checkers, on documents of their own


def test_slug_follows_githubs_rules():
    assert slug("What the testbed refuses, and why") == "what-the-testbed-refuses-and-why"
    assert slug("Large airspace fences (GeoJSON)") == "large-airspace-fences-geojson"
    assert slug("The `geofence:` block") == "the-geofence-block"
    assert slug("results.csv columns") == "resultscsv-columns"
    assert slug("The uncertainty margins are three sigmas (k = 3)") == "the-uncertainty-margins-are-three-sigmas-k--3"
    assert slug("snake_case and kebab-case") == "snake_case-and-kebab-case"
    assert slug("The geofence's own view: sensors, estimator, wind") == "the-geofences-own-view-sensors-estimator-wind"


def test_anchors_number_repeated_headings_and_skip_code_blocks():
    text = "# Top\n\n## Notes\n\n```bash\n# not a heading\n```\n\n## Notes\n"
    assert anchors(text) == {"top", "notes", "notes-1"}


def test_link_checker_finds_a_missing_file_and_a_missing_anchor(tmp_path):
    (tmp_path / "other.md").write_text("# Other\n\n## A section, with punctuation\n")
    doc = tmp_path / "doc.md"
    doc.write_text(
        "# Doc\n\n## Here\n\n"
        "[ok](other.md) [ok](other.md#a-section-with-punctuation) [ok](#here) [ok](https://example.org/x#y)\n"
        "[gone](missing.md) [bad anchor](other.md#no-such-section) [bad self](#nowhere)\n"
        "`[in a code span](missing2.md)`\n\n```\n[in a block](missing3.md)\n```\n"
    )
    problems = broken_links(doc)
    assert len(problems) == 3, problems
    assert any("missing.md" in p for p in problems)
    assert any("#no-such-section" in p for p in problems)
    assert any("#nowhere" in p for p in problems)


def test_command_checker_finds_an_unknown_subcommand_an_unknown_option_and_a_missing_path():
    script = (
        "geofence-testbed run scenarios/multicopter_survey_wind.yaml --out out/  # fine\n"
        "geofence-testbed fly scenarios/multicopter_survey_wind.yaml\n"
        "geofence-testbed batch scenarios/ci --jobz 2\n"
        "pip install -e . && geofence-testbed run scenarios/no_such_scenario.yaml --out scenarios/new_output\n"
    )
    problems = command_problems(script, ROOT)
    assert len(problems) == 3, problems
    assert any("fly" in p and "invalid choice" in p for p in problems)
    assert any("--jobz" in p for p in problems)
    assert any("scenarios/no_such_scenario.yaml" in p for p in problems)
    assert command_problems("geofence-testbed --version\ngeofence-testbed campaign report r --campaign c\n", ROOT) == []


def test_campaign_anchor_checker_finds_a_missing_heading(tmp_path):
    code = tmp_path / "mod.py"
    code.write_text('"""Sound (case history: docs/campaigns.md#here)."""\n# (case history: docs/campaigns.md#gone)\n')
    problems = campaign_anchor_problems([code], anchors("# Top\n\n## Here\n"))
    assert len(problems) == 1 and "#gone" in problems[0] and "mod.py:2" in problems[0], problems


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
def test_bash_syntax_check_can_fail():
    assert bash_syntax_error("echo ok && ls\n") is None
    assert bash_syntax_error("if true; then echo 'unterminated\n") is not None


# ---------------------------------------------------------------------------------------------- the repository's documents


def test_the_documents_exist():
    for doc in (README, ROOT / "CONTRIBUTING.md", ROOT / "LICENSE"):
        assert doc.is_file(), doc


@pytest.mark.parametrize("doc", DOC_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    if not doc.is_file():
        pytest.fail(f"{doc.relative_to(ROOT)} is missing")
    assert broken_links(doc) == []


def test_campaign_anchors_in_the_code_resolve():
    files = code_files()
    assert files, "no .py files found under the packages"
    assert campaign_anchor_problems(files, anchors(CAMPAIGNS.read_text(encoding="utf-8"))) == []


def test_readme_is_at_most_300_lines():
    n_lines = len(README.read_text(encoding="utf-8").splitlines())
    assert n_lines <= README_MAX_LINES, f"README.md has {n_lines} lines; move detail to docs/ (at most {README_MAX_LINES})"


def test_readme_has_shell_blocks():
    assert len(readme_shell_blocks()) >= 2  # the two commands on a fresh machine, at least


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
@pytest.mark.parametrize("index, script", readme_shell_blocks(), ids=[f"block{i}" for i, _ in readme_shell_blocks()])
def test_readme_shell_blocks_parse(index, script):
    assert bash_syntax_error(script) is None, f"README shell block {index}"
    assert command_problems(script, ROOT) == [], f"README shell block {index}"


def readme_scenarios() -> list[str]:
    out = []
    for lang, body in blocks(README.read_text(encoding="utf-8")):
        if lang in ("yaml", "yml"):
            doc = yaml.safe_load(body)
            if isinstance(doc, dict) and "aircraft" in doc:
                out.append(body)
    return out


@pytest.mark.parametrize("body", readme_scenarios(), ids=lambda b: str(yaml.safe_load(b).get("name", "scenario")))
def test_readme_scenarios_validate(body, tmp_path, capsys):
    path = tmp_path / "scenario.yaml"
    path.write_text(body)
    assert cli_main(["validate", str(path)]) == 0, capsys.readouterr().err
