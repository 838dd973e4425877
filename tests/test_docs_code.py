"""Every code block of the README and the docs runs (issue 29): Python blocks are executed, TOML
robot files are read, and every ``ismpc`` command parses with the real argument parser.

Python blocks run in a fresh folder holding ``robots/mybot.toml`` (a copy of the built-in OP3
file, named "mybot"), the robot file the docs' examples assume a reader has drafted. Blocks that
simulate for long are listed in :data:`SLOW_BLOCKS` and run by the slow variant only; the slow
variant also runs the README's Quickstart commands, with the wizard's ``MODEL.xml`` a model that is
not one of ours (``tests/mujoco_fixtures.py``).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from robust_ismpc.cli import args as cli_args
from robust_ismpc.cli import main
from robust_ismpc.robots.robot_file import BUILTIN_DIR, read_robot_file
from robust_ismpc.runs.forces import parse_force, parse_push

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["README.md", *sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").glob("*.md"))]

#: Python blocks that simulate for minutes: (page, a line of the block) -> why. Run only by the
#: slow variant.
SLOW_BLOCKS = {
    ("docs/sweeps.md", "result = run_sweep(config, \"sweeps/small\", workers=2)"):
        "a sweep of 2 controllers x 2 directions x 2 phases, 9 trials each",
}


def code_blocks(page: str, languages: tuple[str, ...]) -> list[tuple[int, str]]:
    """(first line number, text) of the fenced blocks of ``page`` in one of ``languages``."""
    blocks, current, start, language = [], None, 0, ""
    for number, line in enumerate((ROOT / page).read_text().splitlines(), 1):
        fence = re.match(r"^\s*```\s*([\w-]*)", line)
        if fence and current is None:
            current, start, language = [], number + 1, fence.group(1)
        elif fence and line.strip() == "```":
            if language in languages:
                blocks.append((start, "\n".join(current)))
            current = None
        elif current is not None:
            current.append(line)
    return blocks


def _python_blocks(slow: bool) -> list:
    found = []
    for page in PAGES:
        for line, text in code_blocks(page, ("python", "py")):
            reason = next((why for (p, key), why in SLOW_BLOCKS.items() if p == page and key in text), None)
            if (reason is not None) == slow:
                found.append(pytest.param(page, line, text, id=f"{page}:{line}"))
    return found


def test_every_slow_block_is_in_the_docs():
    """Each entry of SLOW_BLOCKS names a block that exists (an edited block must be re-listed)."""
    texts = {(page, key) for page, key in SLOW_BLOCKS
             if any(key in text for _, text in code_blocks(page, ("python", "py")))}
    assert texts == set(SLOW_BLOCKS)


@pytest.fixture
def reader_folder(tmp_path, monkeypatch) -> Path:
    """A fresh working folder with the robot file the docs assume: robots/mybot.toml."""
    (tmp_path / "robots").mkdir()
    text = (BUILTIN_DIR / "op3.toml").read_text().replace('name = "op3"', 'name = "mybot"')
    (tmp_path / "robots" / "mybot.toml").write_text(text)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _execute(page: str, line: int, text: str) -> None:
    code = compile("\n" * (line - 1) + text, page, "exec")  # the page and line in a traceback
    exec(code, {"__name__": "__docs__"})  # noqa: S102  (the docs' own examples)


@pytest.mark.parametrize("page,line,text", _python_blocks(slow=False))
def test_python_blocks_run(reader_folder, page, line, text):
    """Every quick ```python block of the README and the docs runs without an error."""
    pytest.importorskip("mujoco")
    _execute(page, line, text)


@pytest.mark.slow
@pytest.mark.parametrize("page,line,text", _python_blocks(slow=True))
def test_slow_python_blocks_run(reader_folder, page, line, text):
    """The ```python blocks that simulate for long run without an error."""
    _execute(page, line, text)


@pytest.mark.parametrize("page,line,text", [pytest.param(page, line, text, id=f"{page}:{line}")
                                            for page in PAGES for line, text in code_blocks(page, ("toml",))])
def test_toml_blocks_are_robot_files(reader_folder, page, line, text):
    """Every ```toml block is a robot file whose keys and types are right (its model is not opened)."""
    path = reader_folder / "robots" / "example.toml"
    path.write_text(text)
    read_robot_file(path)


def _commands(text: str) -> list[list[str]]:
    """The ``ismpc`` commands of a shell text: lines joined at a trailing backslash, split at
    ``&&``, ``;`` and ``|``, comments dropped; each as its words after ``ismpc``."""
    commands = []
    for line in text.replace("\\\n", " ").splitlines():
        if "ismpc" not in line:
            continue
        lexer = shlex.shlex(line, posix=True, punctuation_chars=";&|")
        lexer.whitespace_split, lexer.commenters = True, "#"
        try:
            tokens = [*lexer, ";"]
        except ValueError:  # not shell (prose in a plain block), unless it starts as a command
            assert not line.lstrip().startswith("ismpc "), f"cannot split {line!r}"
            continue
        words: list[str] = []
        for token in tokens:
            if token.strip(";&|"):
                words.append(token)
                continue
            while words and words[0] in ("do", "then", "time"):
                words = words[1:]
            if words and words[0] == "ismpc":
                commands.append(words[1:])
            words = []
    return commands


class _ParseError(Exception):
    pass


@pytest.fixture
def parser(monkeypatch):
    """The ``ismpc`` parser, raising :class:`_ParseError` with argparse's message."""

    def error(self, message):
        raise _ParseError(message)

    monkeypatch.setattr(cli_args._Parser, "error", error)
    return cli_args.build_parser()


def _shell_commands() -> list:
    return [pytest.param(page, line, words, id=f"{page}:{line}:{' '.join(words[:2])}")
            for page in PAGES for line, text in code_blocks(page, ("bash", "sh", "shell", "console", ""))
            for words in _commands(text)]


@pytest.mark.parametrize("page,line,words", _shell_commands())
def test_shell_block_commands_parse(parser, page, line, words):
    """Every ``ismpc`` command of a ```bash block (or a plain ``` block; ```text is not code)
    parses with every flag it needs, and its ``--force``/``--push`` values are valid."""
    try:
        parsed = parser.parse_args(words)
    except SystemExit as exc:  # --help
        assert exc.code == 0
        return
    except _ParseError as exc:
        pytest.fail(f"{page}:{line}: `ismpc {' '.join(words)}`: {exc}")
    for text in getattr(parsed, "force", None) or []:
        parse_force(text)
    for text in getattr(parsed, "push", None) or []:
        parse_push(text)


#: Inline mentions that are notation, not a command: elisions, alternatives, optional parts.
_NOTATION = re.compile(r"\.\.\.|\||\[")


def _inline_commands() -> list:
    found = []
    for page in PAGES:
        text = re.sub(r"```.*?```", "", (ROOT / page).read_text(), flags=re.S)
        for span in re.findall(r"`(ismpc [^`]*)`", text):
            if not _NOTATION.search(span):
                found.append(pytest.param(page, span, id=f"{page}:{span[:40]}"))
    return found


@pytest.mark.parametrize("page,span", _inline_commands())
def test_inline_commands_name_real_flags(parser, page, span):
    """Every ``ismpc ...`` mentioned in the text names a real command and real flags with valid
    values; a mention may leave out required flags (`ismpc robot check`)."""
    try:
        parser.parse_args(shlex.split(span)[1:])
    except SystemExit as exc:  # --help
        assert exc.code == 0
    except _ParseError as exc:
        if "the following arguments are required" not in str(exc):
            pytest.fail(f"{page}: `{span}`: {exc}")


def _quickstart_commands() -> list[list[str]]:
    table = (ROOT / "README.md").read_text().split("## Quickstart", 1)[1].split("\n## ", 1)[0]
    return [shlex.split(span)[1:] for span in re.findall(r"`(ismpc [^`]*--out [^`]*)`", table)]


def test_the_quickstart_is_found():
    """The README's Quickstart lists its commands (the slow test runs them)."""
    assert len(_quickstart_commands()) >= 7


@pytest.mark.slow
def test_the_quickstart_runs_as_a_newcomer_would(reader_folder, capsys):
    """Every Quickstart command of the README runs in a fresh folder, in order, and exits 0;
    the wizard's MODEL.xml is a humanoid that is not one of ours."""
    pytest.importorskip("mujoco")
    from mujoco_fixtures import newcomer_scene

    model = newcomer_scene(reader_folder / "newcomer")
    (reader_folder / "robots" / "mybot.toml").unlink()  # the wizard writes it
    for words in _quickstart_commands():
        words = [str(model) if w == "MODEL.xml" else w for w in words]
        if words[:2] == ["robot", "init"]:
            words.append("--no-calibrate")
        code = main(words + ["--quiet"] * (words[0] in ("run", "compare", "sweep", "soak")))
        assert code == 0, (words, capsys.readouterr().err)


def _dotted_names() -> list:
    found = []
    for page in PAGES:
        for name in sorted(set(re.findall(r"robust_ismpc(?:\.[A-Za-z_]\w*)+", (ROOT / page).read_text()))):
            found.append(pytest.param(page, name, id=f"{page}:{name}"))
    return found


@pytest.mark.parametrize("page,name", _dotted_names())
def test_dotted_names_in_the_docs_exist(page, name):
    """Every ``robust_ismpc.a.b`` the docs name is a module or an attribute of one (a reader who
    imports it finds it)."""
    import importlib

    parts = name.split(".")
    for split in range(len(parts), 0, -1):
        try:
            found = importlib.import_module(".".join(parts[:split]))
            break
        except ModuleNotFoundError:
            continue
    for attribute in parts[split:]:
        assert hasattr(found, attribute), f"{page}: {name}: no {attribute!r} in {found.__name__}"
        found = getattr(found, attribute)
