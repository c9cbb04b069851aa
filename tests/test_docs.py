"""The README and the pages under docs/ say true things: their links lead somewhere, the
commands and options they show exist, the scenarios they name load, the runnable snippets
run, and every generated result table (the README's headline among them) is what
``tools/results_tables.py`` makes from the committed result files; and no file of the
repository names a directory of the machine that made it."""

from __future__ import annotations

import argparse
import functools
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tangle_drake.cli import build_parser
from tangle_drake.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").rglob("*.md"))
CARD = ROOT / "tangle_drake" / "trained" / "README.md"
TOOLS = ROOT / "tools"
PAGES = [README, *DOCS, CARD, TOOLS / "README.md"]
"""Every page a user reads: the README, docs/ (generated reports included) and the model card."""

README_MAX_LINES = 300
HEADLINE_WITHIN = 80
HEADLINE_START = "<!-- headline -->"
HEADLINE_END = "<!-- /headline -->"
RUNNABLE = "<!-- runnable -->"
SNIPPET_TIMEOUT_S = 120



def relative(page: Path) -> str:
    return str(page.relative_to(ROOT))


# --- (a) links --------------------------------------------------------------------------------

LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")


def prose(text: str) -> str:
    """``text`` without its fenced code blocks and inline code (links there are not links)."""
    lines, fenced = [], False
    for line in text.splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            lines.append(re.sub(r"`[^`]*`", "", line))
    return "\n".join(lines)


def relative_links(page: Path) -> list[str]:
    """The page's links that point at a file of this repository (anchors stripped)."""
    targets = []
    for target in LINK.findall(prose(page.read_text())):
        if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
            continue  # a URL (https:, mailto:) or an anchor in the same page
        targets.append(target.split("#", 1)[0])
    return targets


@pytest.mark.parametrize("page", PAGES, ids=relative)
def test_every_relative_link_resolves_to_a_file(page):
    broken = [target for target in relative_links(page) if not (page.parent / target).exists()]
    assert not broken, f"{relative(page)}: links to nothing: {broken}"


def test_the_docs_index_links_every_page():
    index = ROOT / "docs" / "index.md"
    linked = {(index.parent / target).resolve() for target in relative_links(index)}
    pages = [page for page in (ROOT / "docs").glob("*.md") if page != index]
    pages += [ROOT / "docs" / "results" / "history.md"]
    missing = [relative(page) for page in pages if page.resolve() not in linked]
    assert not missing, f"docs/index.md does not link {missing}"


# --- (b) commands and options ------------------------------------------------------------------

def code_blocks(text: str, languages: tuple[str, ...] | None = None) -> list[list[str]]:
    """The fenced code blocks of ``text`` (their lines), of the given info strings if any."""
    blocks, current, language = [], None, ""
    for line in text.splitlines():
        fence = FENCE.match(line)
        if fence and current is None:
            current, language = [], line.strip()[3:].strip().lower()
        elif fence:
            if languages is None or language in languages:
                blocks.append(current)
            current = None
        elif current is not None:
            current.append(line)
    return blocks


COMMAND_START = re.compile(r"^(?:[A-Z_][A-Z0-9_]*=\S*\s+)*(?:\S*/)?tangle-drake(?:\s|$)")
OPTION = re.compile(r"(?<![\w-])--[a-zA-Z][a-zA-Z0-9-]*")


def command_lines(text: str) -> list[str]:
    """The ``tangle-drake`` command lines of the fenced code blocks, continuation lines
    (a trailing backslash, or an indented line after a command) joined to them and comments
    dropped."""
    commands = []
    for block in code_blocks(text):
        current = None
        for line in block:
            body = re.sub(r"(^|\s)#.*$", "", line).rstrip()
            if current is not None and (current.endswith("\\") or
                                        (line[:1].isspace() and body.strip())):
                current = current.rstrip("\\").rstrip() + " " + body.strip()
                continue
            if current is not None:
                commands.append(current)
                current = None
            if COMMAND_START.match(body.strip()):
                current = body.strip()
        if current is not None:
            commands.append(current)
    return [command.rstrip("\\").rstrip() for command in commands]


@functools.cache
def parsers() -> dict[str | None, argparse.ArgumentParser]:
    """The CLI's parsers, built in-process: ``None`` for the top level, else by subcommand."""
    parser = build_parser()
    found: dict[str | None, argparse.ArgumentParser] = {None: parser}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            found.update(action.choices)
    return found


def option_strings(parser: argparse.ArgumentParser) -> set[str]:
    return {option for action in parser._actions for option in action.option_strings}


def documented_commands() -> list[tuple[str, str]]:
    return [(relative(page), command) for page in PAGES
            for command in command_lines(page.read_text())]


def test_the_docs_show_commands():
    pages = {page for page, _ in documented_commands()}
    for page in ("README.md", "docs/pick-demo.md", "docs/benchmark.md",
                 "docs/data-and-training.md", "docs/teach.md", "docs/graspability.md"):
        assert page in pages, f"{page} shows no tangle-drake command"


@pytest.mark.parametrize(("page", "command"), documented_commands(),
                         ids=[f"{page}: {command[:60]}" for page, command in
                              documented_commands()])
def test_every_documented_subcommand_and_option_exists(page, command):
    words = re.sub(r"[\[\]|]", " ", command.split("tangle-drake", 1)[1]).split()
    subcommand = next((word for word in words if not word.startswith("-")), None)
    known = parsers()
    if words and words[0].startswith("-"):
        subcommand = None  # tangle-drake --version
    assert subcommand in known, f"{page}: no subcommand {subcommand!r} in `{command}`"
    unknown = sorted(set(OPTION.findall(command)) - option_strings(known[subcommand]))
    assert not unknown, f"{page}: `tangle-drake {subcommand}` has no {unknown}"


def test_the_command_parser_reads_what_the_pages_write():
    text = "\n".join(["```bash", "tangle-drake bench [--methods a b] [--parts u_hook] \\",
                      "    --out results/x   # a comment --not-an-option",
                      "OMP_NUM_THREADS=1 tangle-drake train --data d",
                      "tangle-drake demo [--picks 5]",
                      "                  [--seed 3]",
                      "python tools/x.py --no",
                      "```", "tangle-drake scene --not-in-a-block"])
    assert command_lines(text) == [
        "tangle-drake bench [--methods a b] [--parts u_hook] --out results/x",
        "OMP_NUM_THREADS=1 tangle-drake train --data d",
        "tangle-drake demo [--picks 5] [--seed 3]"]


# --- (c) scenarios ------------------------------------------------------------------------------

SCENARIO_PATH = re.compile(
    r"(?<![\w/.-])(diagrams/[\w./-]+?\.yaml)")


def documented_scenarios() -> list[str]:
    return sorted({path for page in PAGES for path in SCENARIO_PATH.findall(page.read_text())})


def test_the_docs_name_scenarios():
    assert "diagrams/pick_demo.yaml" in documented_scenarios()


@pytest.mark.parametrize("path", documented_scenarios())
def test_every_named_scenario_loads(path):
    load_scenario(ROOT / path)


# --- (d) the README's shape ---------------------------------------------------------------------

def headline() -> tuple[int, list[str]]:
    """The line number (1-based) of the headline's marker and the lines up to its end."""
    lines = README.read_text().splitlines()
    assert lines.count(HEADLINE_START) == 1, f"README.md needs one {HEADLINE_START} marker"
    start = lines.index(HEADLINE_START)
    assert HEADLINE_END in lines[start:], f"README.md: {HEADLINE_END} after the headline"
    end = lines.index(HEADLINE_END, start)
    return start + 1, lines[start + 1:end]


def test_the_readme_is_short():
    count = len(README.read_text().splitlines())
    assert count <= README_MAX_LINES, f"README.md has {count} lines, more than {README_MAX_LINES}"


def test_the_headline_table_is_near_the_top():
    start, lines = headline()
    end = start + len(lines) + 1
    assert end <= HEADLINE_WITHIN, f"the headline runs to line {end}, past {HEADLINE_WITHIN}"
    assert any(line.startswith("|") for line in lines), "the headline holds no table"


def test_the_readme_keeps_its_two_set_up_commands():
    text = README.read_text()
    assert "make demo" in text and "make test" in text
    first = text.index("make demo")
    assert first < text.index(HEADLINE_START), "the set-up commands come before the results"


# --- (e) the result tables ---------------------------------------------------------------------

def load_tool():
    """``tools/results_tables.py`` as a module (registered, as its dataclasses need)."""
    spec = importlib.util.spec_from_file_location("results_tables", TOOLS / "results_tables.py")
    tool = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = tool
    spec.loader.exec_module(tool)
    return tool


TABLES = load_tool()


def tables(lines: list[str]) -> list[list[str]]:
    """The Markdown tables among ``lines``, each as its lines (header first)."""
    found, current = [], []
    for line in [*lines, ""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            found.append(current)
            current = []
    return found


def backticked(cell: str) -> str | None:
    match = re.search(r"`([^`]+)`", cell)
    return match.group(1) if match else None


def cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def test_the_headline_is_a_generated_table():
    assert (README, "headline") in TABLES.generated_blocks()


@pytest.mark.parametrize(("page", "name"), TABLES.generated_blocks(),
                         ids=[f"{relative(page)}: {name}"
                              for page, name in TABLES.generated_blocks()])
def test_every_generated_table_is_its_result_files(page, name):
    """What ``python tools/results_tables.py --check`` checks, one block at a time."""
    stale = [block for block in TABLES.stale(page) if block == f"{relative(page)}: {name}"]
    assert not stale, (f"{stale[0]} disagrees with its result files: run "
                       "`python tools/results_tables.py` and commit the page")


def test_the_table_check_names_a_block_that_disagrees_with_its_files():
    """One figure changed by hand is named by its block, and the tool writes it back; the
    tool run on what it wrote changes nothing."""
    text = README.read_text()
    _, lines = headline()
    figure = tables(lines)[0][2]
    changed = re.sub(r"(\d+\.)(\d) %", lambda m: f"{m[1]}{(int(m[2]) + 1) % 10} %", figure,
                     count=1)
    edited = text.replace(figure, changed, 1)
    assert edited != text
    assert TABLES.stale(README, edited) == ["README.md: headline"]
    made, _ = TABLES.render(README, edited)
    assert TABLES.render(README, made) == (made, [])
    assert changed not in made


def test_the_tables_tool_checks_the_committed_pages(capsys):
    assert TABLES.main(["--check"]) == 0, capsys.readouterr().out


def test_a_docs_page_marks_its_tables_by_name():
    """A ``<!-- table: NAME -->`` block on a page under docs/ gets the table with links from
    that page; a name the tool does not know is an error naming the page and line."""
    page = ROOT / "docs" / "some_page.md"
    text = "Before.\n\n<!-- table: headline -->\nby hand\n<!-- /table -->\n\nAfter.\n"
    made, changed = TABLES.render(page, text)
    assert changed == ["docs/some_page.md: headline"]
    assert made.startswith("Before.\n\n<!-- table: headline -->\n| first pick")
    assert made.endswith("<!-- /table -->\n\nAfter.\n") and "by hand" not in made
    assert "[one layer](results/benchmark/report.md)" in made
    with pytest.raises(TABLES.TableError, match=r"some_page.md:1: no table named 'nothing'"):
        TABLES.render(page, "<!-- table: nothing -->\n<!-- /table -->\n")
    with pytest.raises(TABLES.TableError, match="without its <!-- /table -->"):
        TABLES.render(page, "<!-- table: headline -->\n")


def test_the_headline_links_its_four_results():
    _, lines = headline()
    linked = [re.search(r"\]\(([^)]+)\)", row).group(1)
              for table in tables(lines) for row in table[2:]]
    assert sorted(linked) == sorted([
        "docs/results/benchmark/report.md", "docs/results/dense_comparison/report.md",
        "docs/results/clearing/closed/clear_report.md",
        "docs/results/clearing/arm_brisk_6cm/clear_report.md"])


def test_the_headline_names_the_benchmarks_methods():
    _, lines = headline()
    header = cells(tables(lines)[0][0])
    assert [backticked(cell) for cell in header[1:]] == [
        "random", "graspability", "cnn", "harmonic", "success-cnn", "outcome"]
    assert "bins cleared" not in "\n".join(lines).lower()


# --- (f) the result pages -----------------------------------------------------------------------

RESULTS = ROOT / "docs" / "results"
NOT_RESULTS = {"clearing/overlays", "superseded"}
"""Folders under docs/results that hold no result of their own: the clearings' scenario
overlays, the superseded ones' parent."""
RESULT_FIELDS = ("Remake", "Commit", "Machine", "Data")
FIELD = re.compile(r"^- \*\*(\w+):\*\* (.+)$")
SCRIPT = re.compile(r"(?<![\w/.-])python3? ((?:tools|examples)/[\w/-]+\.py)((?: [^`\n]*)?)")


def result_folders() -> list[str]:
    """Every folder under docs/results holding a result's files (anything but pages)."""
    folders = {path.parent for path in RESULTS.rglob("*") if path.is_file()
               and path.suffix != ".md"}
    return sorted(str(folder.relative_to(RESULTS)) for folder in folders
                  if str(folder.relative_to(RESULTS)) not in NOT_RESULTS)


def page_fields(page: Path) -> dict[str, str]:
    """The ``- **Field:** value`` lines that open a result page (before its first paragraph
    of prose after them)."""
    fields: dict[str, str] = {}
    for line in page.read_text().splitlines()[:12]:
        if match := FIELD.match(line):
            fields[match.group(1)] = match.group(2)
    return fields


def test_there_are_result_folders():
    assert {"benchmark", "dense_comparison", "clearing/closed"} <= set(result_folders())


@pytest.mark.parametrize("folder", result_folders())
def test_every_result_has_a_page_beside_its_data(folder):
    page = RESULTS / folder / "README.md"
    assert page.is_file(), f"docs/results/{folder} has data but no README.md page"
    fields = page_fields(page)
    missing = [name for name in RESULT_FIELDS if name not in fields]
    assert not missing, f"docs/results/{folder}/README.md does not open with {missing}"
    assert re.match(r"`[0-9a-f]{7,40}`", fields["Commit"]), fields["Commit"]
    remake = re.fullmatch(r"`([^`]+)`.*", fields["Remake"])
    assert remake, f"docs/results/{folder}: the remake command is not in backticks"
    command = remake.group(1)
    if "tangle-drake" in command:
        test_every_documented_subcommand_and_option_exists(f"docs/results/{folder}", command)
    else:
        assert SCRIPT.match(command), f"docs/results/{folder}: `{command}` runs nothing known"
    named = [path for path in re.findall(r"docs/results/[\w./-]+", command)
             if not path.startswith("docs/results/clearing/overlays/")]  # inputs
    assert all(path.startswith(f"docs/results/{folder}") for path in named), \
        f"docs/results/{folder}: `{command}` writes elsewhere"
    linked = relative_links(page)
    assert any(not target.endswith(".md") for target in linked), \
        f"docs/results/{folder}/README.md links none of its data files"


def test_the_results_index_links_every_result_page():
    index = RESULTS / "README.md"
    linked = {(index.parent / target).resolve() for target in relative_links(index)}
    missing = [folder for folder in result_folders()
               if (RESULTS / folder / "README.md").resolve() not in linked]
    assert not missing, f"docs/results/README.md does not link {missing}"


def test_every_tool_is_listed_once_in_the_tools_readme():
    listed = re.findall(r"^\| `(\w+\.py)` \|", (TOOLS / "README.md").read_text(), re.M)
    assert sorted(listed) == sorted(path.name for path in TOOLS.glob("*.py"))


def named_scripts() -> list[tuple[str, str, str]]:
    """(page, script, its arguments) for every ``python tools/...`` or ``python
    examples/...`` a page names."""
    return sorted({(relative(page), match.group(1), match.group(2).strip())
                   for page in PAGES
                   for match in SCRIPT.finditer(re.sub(r"\\\n\s*", " ", page.read_text()))})


@pytest.mark.parametrize(("page", "script", "arguments"), named_scripts(),
                         ids=[f"{page}: {script}" for page, script, _ in named_scripts()])
def test_every_named_script_exists_with_its_options(page, script, arguments):
    path = ROOT / script
    assert path.is_file(), f"{page}: names {script}, which is not in the repository"
    source = path.read_text()
    unknown = [option for option in OPTION.findall(arguments)
               if f'"{option}"' not in source and f"'{option}'" not in source]
    assert not unknown, f"{page}: {script} has no option {unknown}"


# --- (g) no machine's paths ----------------------------------------------------------------------

MACHINE_PATH = re.compile(r"(?<![\w.~/-])/(?:work|root|home|tmp)/[^\s\"'`]*")
"""An absolute path under a machine's own directories (URLs' paths follow a host, not this)."""


def tracked_text_files() -> list[Path]:
    """The repository's tracked files outside tests/ that are text (no NUL byte)."""
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True)
    if listed.returncode != 0:
        pytest.skip("not a git checkout")
    files = [ROOT / name for name in listed.stdout.decode().split("\0")
             if name and not name.startswith("tests/")]
    return [path for path in files if path.is_file() and b"\0" not in path.read_bytes()[:8000]]


def test_no_file_names_a_path_of_the_machine_that_made_it():
    """Results record paths as ``tangle_drake.common.paths.shown_path`` writes them: relative, or
    under ``DATA/``."""
    found = [f"{path.relative_to(ROOT)}:{number}: {match.group(0)}"
             for path in tracked_text_files()
             for number, line in enumerate(path.read_bytes().decode(errors="replace")
                                           .splitlines(), 1)
             for match in MACHINE_PATH.finditer(line)]
    assert not found, "absolute paths of a machine:\n" + "\n".join(found[:20])


# --- (h) runnable snippets ----------------------------------------------------------------------

def runnable_snippets() -> list[tuple[str, str]]:
    """The ```python blocks a ``<!-- runnable -->`` comment marks (the comment alone on the
    line before the fence, blank lines allowed between)."""
    found = []
    for page in PAGES:
        lines = page.read_text().splitlines()
        for number, line in enumerate(lines):
            if line.strip() != RUNNABLE:
                continue
            fence = next(i for i in range(number + 1, len(lines)) if lines[i].strip())
            assert lines[fence].strip() == "```python", f"{relative(page)}:{number + 1}"
            end = next(i for i in range(fence + 1, len(lines)) if FENCE.match(lines[i]))
            found.append((f"{relative(page)}:{fence + 1}", "\n".join(lines[fence + 1:end])))
    return found


def python_snippets() -> list[tuple[str, str]]:
    return [(f"{relative(page)} #{number}", "\n".join(block)) for page in PAGES
            for number, block in enumerate(code_blocks(page.read_text(), ("python",)), 1)]


@pytest.mark.parametrize(("where", "code"), python_snippets(),
                         ids=[where for where, _ in python_snippets()])
def test_every_python_snippet_is_python(where, code):
    """Snippets too costly to run (a pile to settle, a station of your own) still parse."""
    compile(code, where, "exec")


def test_some_snippets_are_runnable():
    assert runnable_snippets()


@pytest.mark.parametrize(("where", "code"), runnable_snippets(),
                         ids=[where for where, _ in runnable_snippets()])
def test_a_runnable_snippet_runs(where, code):
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=SNIPPET_TIMEOUT_S)
    assert run.returncode == 0, f"{where} failed:\n{run.stderr[-3000:]}"
