"""The commands the README and the guide (``docs/*.md``) show, read from
their shell code blocks, for the tests that run them: ``test_docs.py``
(the engine's, the benchmarks', the cluster's) and
``blender/test_docs_commands.py`` (``blender --command lipsync``).

A command is a line of a ```` ```sh ```` (``bash``, ``shell``) block, with
its ``\\`` continuations joined and its ``# comment`` cut off, or a line of a
```` ```console ```` block starting with ``$ `` (the lines after it are its
output).  A block just after an HTML comment ``<!-- file: NAME -->`` is a
file the page's commands use (a manifest, a track map), written as NAME
where they run.  A ```` ```python ```` block is a program, run whole
(:func:`python_blocks`).

Standard library only: the Blender tests import it on every Blender's
Python.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHELL = ("sh", "bash", "shell")
CONSOLE = "console"
PYTHON = ("python", "py")
_FENCE = re.compile(r"^```(\S*)\s*$")
_FILE = re.compile(r"^<!--\s*file:\s*(\S+)\s*-->\s*$")


@dataclass
class Command:
    page: str           # the page, relative to the repository ("docs/blender.md")
    line: int           # the line the command starts on
    text: str           # the command, continuations joined, comment cut off
    output: list[str] = field(default_factory=list)   # a console block's lines shown after it

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def key(self) -> str:
        """The command with its spaces collapsed: how registries name it."""
        return " ".join(self.text.split())


@dataclass
class Block:
    page: str
    line: int           # the line of its opening fence
    lang: str
    body: list[str]
    file: str | None = None   # the name it is written as (``<!-- file: NAME -->``), or None

    def commands(self) -> list[Command]:
        if self.lang in SHELL:
            return _shell_commands(self)
        if self.lang == CONSOLE:
            return _console_commands(self)
        return []


def pages(root: Path = ROOT) -> list[Path]:
    """The README and every page of the guide."""
    return [root / "README.md"] + sorted((root / "docs").glob("*.md"))


def blocks(path: Path, root: Path = ROOT) -> list[Block]:
    """The fenced code blocks of a page, in order."""
    page = path.relative_to(root).as_posix()
    out: list[Block] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    k = 0
    pending_file = None
    while k < len(lines):
        m = _FENCE.match(lines[k])
        if m is None:
            f = _FILE.match(lines[k].strip())
            if f:
                pending_file = f.group(1)
            elif lines[k].strip():
                pending_file = None
            k += 1
            continue
        start = k
        k += 1
        body = []
        while k < len(lines) and not lines[k].startswith("```"):
            body.append(lines[k])
            k += 1
        out.append(Block(page, start + 1, m.group(1).lower(), body, pending_file))
        pending_file = None
        k += 1
    return out


def all_blocks(root: Path = ROOT) -> list[Block]:
    return [b for p in pages(root) for b in blocks(p, root)]


def all_commands(root: Path = ROOT) -> list[Command]:
    return [c for b in all_blocks(root) for c in b.commands()]


def python_blocks(root: Path = ROOT) -> list[Block]:
    """The pages' Python programs (```` ```python ```` blocks)."""
    return [b for b in all_blocks(root) if b.lang in PYTHON]


def files(page: str, root: Path = ROOT) -> dict[str, str]:
    """The files a page declares (``<!-- file: NAME -->``): name -> content."""
    return {b.file: "\n".join(b.body) + "\n" for b in blocks(root / page, root) if b.file}


def cut_comment(line: str) -> str:
    """``line`` without a shell comment: a ``#`` at the start of a word,
    outside quotes."""
    quote = None
    for k, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
            elif ch == "\\" and quote == '"':
                continue
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (k == 0 or line[k - 1].isspace()):
            return line[:k].rstrip()
    return line.rstrip()


def _joined(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """(line number, text) with ``\\`` continuations joined."""
    out: list[tuple[int, str]] = []
    held: tuple[int, str] | None = None
    for n, text in lines:
        if held is not None:
            text = held[1] + " " + text.strip()
            n = held[0]
            held = None
        if text.endswith("\\"):
            held = (n, text[:-1].rstrip())
            continue
        out.append((n, text))
    if held is not None:
        out.append(held)
    return out


def _shell_commands(block: Block) -> list[Command]:
    raw = [(block.line + 1 + k, cut_comment(text)) for k, text in enumerate(block.body)]
    return [Command(block.page, n, text.strip()) for n, text in _joined(raw) if text.strip()]


def _console_commands(block: Block) -> list[Command]:
    out: list[Command] = []
    for k, text in enumerate(block.body):
        if text.startswith("$ "):
            out.append(Command(block.page, block.line + 1 + k, cut_comment(text[2:]).strip()))
        elif out:
            out[-1].output.append(text)
    return out


# --- blender --command lipsync ------------------------------------------------------

def is_blender_command(text: str) -> bool:
    """A ``blender ... --command lipsync ...`` line."""
    words = shlex.split(text)
    return bool(words) and words[0] == "blender" and "--command" in words and \
        words[words.index("--command") + 1:words.index("--command") + 2] == ["lipsync"]


def blender_argv(text: str) -> tuple[str | None, list[str]]:
    """(the .blend file opened, or None; the arguments the command gets) of
    a ``blender [-b FILE.blend] --command lipsync ARGS`` line.  Anything
    else before ``--command`` is refused (the test could not do it)."""
    words = shlex.split(text)
    blend = None
    k = 1
    while words[k] != "--command":
        if words[k] in ("-b", "--background"):
            pass
        elif words[k].endswith(".blend") and blend is None:
            blend = words[k]
        else:
            raise ValueError(f"{text!r}: {words[k]!r} before --command is not something the tests do")
        k += 1
    return blend, words[k + 2:]


def blender_commands(root: Path = ROOT) -> list[Command]:
    return [c for c in all_commands(root) if is_blender_command(c.text)]
