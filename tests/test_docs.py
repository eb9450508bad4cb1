"""Every command the README and the guide (``docs/*.md``) show works.

The commands are read from the pages' shell code blocks
(:mod:`doccommands`), and each one is

* run here, as written, in a folder of its own (``box``) that holds the
  repository's ``.venv``, ``addon``, ``bench``, ``sample_rigs`` and
  ``tools`` (linked), an ``out/`` folder, the files the page declares
  (``<!-- file: NAME -->`` before a block: a manifest, a track map) and the
  files the commands name (:data:`COPIES`, :data:`WRITTEN`, :data:`BUILT`:
  ``line.wav`` is the shipped sample line, ``lines/*.wav`` three takes with
  synthesized face captures ...).  The commands of one block run in order
  in one folder (a preset learned, then used).  ``LIPSYNC_DATA`` names a
  folder that does not exist, so the benchmarks run as on a machine without
  the recordings: each does what :data:`BENCH` says;
* or, when it cannot run here as written, mapped to the test that runs the
  same thing (:data:`MAPPED`: that test must exist and its source must hold
  the given text), or run only when ``LIPSYNC_SLOW_TESTS=1`` (:data:`SLOW`,
  minutes each);
* ``blender ... --command lipsync ...`` lines are run through ``bpy`` by
  ``tests/blender/test_docs_commands.py`` (there is no ``blender`` binary
  here, only the ``bpy`` module).

A ```` ```python ```` block is a program: it is run whole by the engine's
Python in such a folder, and must exit with status 0.

A command none of these covers fails :func:`test_commands_run` (it runs,
and fails, unless its files are known here), so a new command in the docs
gets a test with it.  The usage synopses (```` ```text ```` blocks of
``python -m addon ...``) name only options the command has, and every link
between the pages resolves.
"""

from __future__ import annotations

import ast
import functools
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import doccommands as dc
from conftest import FIXTURES, ROOT, SAMPLE, write_wav

SLOW_TESTS = os.environ.get("LIPSYNC_SLOW_TESTS") == "1"
SLOW_REASON = "minutes long: set LIPSYNC_SLOW_TESTS=1 to run it"

#: Commands another test runs as they are written, or their exact equivalent:
#: command -> (the test, or the file that runs it; texts its source holds).
MAPPED = {
    # CI's one step (.ci/run) is ./test.sh: every push runs it.
    "./test.sh": (".ci/run", ["exec ./test.sh"]),
    # Every Blender test installs the zip this builds (into a temporary folder instead of dist/).
    ".venv/bin/python tools/build_extension.py --platform linux-x64": (
        "tests/blender/conftest.py::extension_zip", ['"build_extension.py"', '"--platform", "linux-x64"']),
    # A scheduler and workers started with this environment's `dask` (cluster.scheduler() runs
    # `dask scheduler`, on 127.0.0.1), and the batch sent to them.
    "lipsync-env/bin/dask scheduler": (
        "tests/test_cluster.py::test_separate_scheduler_and_workers_run_every_line_as_analyze_does",
        ["cluster.scheduler()"]),
    "lipsync-env/bin/dask worker tcp://10.0.0.5:8786 --nworkers 8 --nthreads 1": (
        "tests/test_cluster.py::test_separate_scheduler_and_workers_run_every_line_as_analyze_does",
        ['cluster.worker("workers", "--nworkers", "2")']),
    ".venv/bin/python -m addon batch /shared/lines.csv --scheduler tcp://10.0.0.5:8786 --out /shared/lipsync": (
        "tests/test_cluster.py::test_separate_scheduler_and_workers_run_every_line_as_analyze_does",
        ['"--scheduler", address']),
    # The same operator call on the toy head, whose strips are keyed first.
    "blender -b bob_lines.blend --python-expr \"import bpy; bpy.ops.emotive_lipsync.learn_preset(mesh='Bob', "
    "name='bob_angry', emotion='angry')\"": (
        "tests/blender/test_extension.py::test_learn_preset_from_the_mesh_animation",
        ["bpy.ops.emotive_lipsync.learn_preset(mesh=", "emotion="]),
}

#: Commands run only with LIPSYNC_SLOW_TESTS=1, in a copy of the repository.
SLOW = {
    "./setup.sh": "builds the environment, then renders the sample scene and its video",
    ".venv/bin/python tools/build_extension.py": "downloads the wheels of four platforms and builds four zips",
}

#: What each benchmark does without ../shared/data: "skips" (prints `skipped: ... not here`
#: and exits 0), "runs" (on synthetic lines or the shipped sample; exits 0), "slow" (the
#: same, but for 10 s to minutes: run with LIPSYNC_SLOW_TESTS=1).
BENCH = {
    "alignment_accuracy": "skips", "arousal": "skips", "batch_throughput": "skips", "boundary_model": "skips",
    "boundary_model_ipa": "skips", "check_cost": "skips",
    "coverage": "skips",
    "crossval": "skips", "crossval_languages": "skips", "crossval_offscript": "skips", "false_alarms": "skips",
    "emodb": "skips",
    "languages": "skips", "learn_real_speech": "skips", "no_transcript": "skips", "offscript": "skips",
    "rhubarb_compare": "skips",
    "speed": "skips", "timing": "skips", "timit": "skips", "gestures": "skips",
    "follow_voice": "runs", "format_alignment": "runs", "learn_speed": "runs",
    "batch_rerun_check": "slow", "blender_generate": "slow", "characters": "slow", "decode_formats": "slow",
    "expression": "slow", "learn_mismatch": "slow", "long_audio": "slow",
}
_BENCH = re.compile(r"^\.venv/bin/python bench/(\w+)\.py")

# --- the files the commands name ----------------------------------------------------

#: Copied into the folder when a command (or a file the page declares) names them, or names a file of
#: the same name with another extension (a transcript beside its audio).
COPIES = {
    "line.wav": SAMPLE / "hello.wav", "line.txt": SAMPLE / "hello.txt",
    "new_line.wav": SAMPLE / "hello.wav", "new_line.txt": SAMPLE / "hello.txt",
    "bob/l001.wav": FIXTURES / "bob_map.wav", "bob/l001.txt": FIXTURES / "bob_map.txt",
    "ann/l002.wav": SAMPLE / "hello.wav",
}
#: Written likewise.
WRITTEN = {
    "ann/l002.txt": "Hallo! Mein Name ist Bob, und ich freue mich sehr, dich kennenzulernen. "
                    "Bitte merk dir meine Stimme.\n",
}
CLIPS = [FIXTURES / "bob_map.wav", FIXTURES / "fast_bilabials.wav", SAMPLE / "hello.wav"]
ARKIT = ["jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLowerDownLeft", "mouthLowerDownRight",
         "mouthStretchLeft", "mouthStretchRight"]


@functools.cache
def _aligned(path: Path):
    from addon.engine import audio as audio_mod
    from addon.engine import pipeline

    snd = audio_mod.load(path)
    return snd, path.with_suffix(".txt").read_text(), pipeline.align_audio(snd, path.with_suffix(".txt").read_text())


def _arkit_takes(box: Path) -> None:
    """``lines/line01.wav`` ... with their transcripts and ARKit face captures
    (``time`` and eight mouth blendshapes), made by the angry preset with the
    ARKit set's poses, plus noise, as tests/test_learn_cli.py makes them."""
    from addon.engine import learning, presets, visemes

    vs = visemes.load("arkit")
    poses = {v: dict(m) for v, m in vs.shape_keys.items()}
    actor = presets.load("angry")
    rng = np.random.default_rng(11)
    folder = box / "lines"
    folder.mkdir(exist_ok=True)
    for k, path in enumerate(CLIPS, 1):
        snd, text, al = _aligned(path)
        probe = learning.TrainingClip("probe", snd, al, np.array([0.0, snd.duration]), np.zeros((2, len(ARKIT))),
                                      ARKIT)
        prepared = learning.prepare(probe, vs, actor, 60.0, ARKIT)
        y = learning.synthesise(prepared, actor, vs, ARKIT, 60.0, poses) + rng.normal(0, 0.01, (len(prepared.times),
                                                                                               len(ARKIT)))
        stem = folder / f"line{k:02d}"
        write_wav(stem.with_suffix(".wav"), snd.samples, snd.rate)
        stem.with_suffix(".txt").write_text(text)
        rows = ["time," + ",".join(ARKIT)] + [f"{t:.5f}," + ",".join(f"{v:.4f}" for v in row)
                                               for t, row in zip(prepared.times, y)]
        stem.with_suffix(".csv").write_text("\n".join(rows) + "\n")


def _ema_takes(box: Path) -> None:
    """``takes/take01.wav`` ... with their transcripts and articulography CSVs
    (``t_ms``, ``JAW_Y`` mm, ``LA`` mm, ``UL_x``, ``p_aa``) from the
    articulatory model of tests/mismatch.py."""
    import mismatch

    folder = box / "takes"
    folder.mkdir(exist_ok=True)
    for k, path in enumerate(CLIPS, 1):
        snd, text, al = _aligned(path)
        times, y = mismatch.capture(al, snd.duration)
        stem = folder / f"take{k:02d}"
        write_wav(stem.with_suffix(".wav"), snd.samples, snd.rate)
        stem.with_suffix(".txt").write_text(text)
        rows = ["t_ms,JAW_Y,LA,UL_x,p_aa"] + [f"{1000 * t:.2f},{20 * a:.3f},{15 * b:.3f},{c:.4f},{a * b:.4f}"
                                               for t, (a, b, c) in zip(times, y)]
        stem.with_suffix(".csv").write_text("\n".join(rows) + "\n")


def _flac(source: Path):
    def build(box: Path, name: str) -> None:
        import soundfile

        from addon.engine import audio as audio_mod

        snd = audio_mod.load(source)
        soundfile.write(box / name, np.asarray(snd.samples), snd.rate, format="FLAC")
    return build


#: Made when named: name (or glob) -> builder.
BUILT = {
    "lines/*.wav": lambda box, _name: _arkit_takes(box),
    "takes/*.wav": lambda box, _name: _ema_takes(box),
    "falsetto.flac": _flac(FIXTURES / "fast_bilabials.wav"),
    "breathy.flac": _flac(FIXTURES / "bob_map.wav"),
}

#: Commands run in a folder of their own: the cluster machines' `pip install` runs against this
#: environment (which requirements.txt made) as `lipsync-env`, with no index and as a dry run: it
#: succeeds only when every version it pins is the one installed, and changes nothing.
DRY_PIP = {"PIP_NO_INDEX": "1", "PIP_DRY_RUN": "1", "PIP_DISABLE_PIP_VERSION_CHECK": "1"}


def _pip_env(box: Path) -> tuple[Path, dict]:
    here = box / "cluster-machine"
    here.mkdir()
    (here / "lipsync-env").symlink_to(ROOT / ".venv")
    return here, DRY_PIP


SPECIAL = {c.key: _pip_env for c in dc.all_commands() if c.key.startswith("lipsync-env/bin/pip install ")}


def _python311() -> str:
    """The Python 3.11 a cluster machine's `python3.11` stands for: this environment's own."""
    assert sys.version_info[:2] == (3, 11), "the engine's environment is Python 3.11"
    return getattr(sys, "_base_executable", sys.executable)


def _box(tmp: Path, page: str, commands: list[dc.Command]) -> Path:
    box = tmp / "box"
    box.mkdir()
    for name in (".venv", "addon", "bench", "sample_rigs", "tools"):
        (box / name).symlink_to(ROOT / name)
    (box / "out").mkdir()
    shims = tmp / "shims"
    shims.mkdir()
    (shims / "python3.11").symlink_to(_python311())
    declared = dc.files(page)
    for name, content in declared.items():
        (box / name).write_text(content, encoding="utf-8")
    named = "\n".join([c.text for c in commands] + list(declared.values()))
    # A file is made when it is named, or a file of the same name with another extension is (the
    # transcript beside an audio file).
    wanted = [name for name in list(COPIES) + list(WRITTEN) if name.rsplit(".", 1)[0] + "." in named]
    for name in wanted:
        (box / name).parent.mkdir(parents=True, exist_ok=True)
        if name in COPIES:
            shutil.copy(COPIES[name], box / name)
        else:
            (box / name).write_text(WRITTEN[name], encoding="utf-8")
    for name, build in BUILT.items():
        if name in named:
            build(box, name)
    return box


def _run(command: dc.Command, box: Path) -> subprocess.CompletedProcess:
    cwd, extra = SPECIAL[command.key](box) if command.key in SPECIAL else (box, {})
    env = dict(os.environ, LIPSYNC_DATA=str(box / "no-recordings-here"),
               PATH=f"{box.parent / 'shims'}{os.pathsep}{os.environ.get('PATH', '')}", **extra)
    return subprocess.run(["bash", "-c", command.text], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=900)


def _said(r: subprocess.CompletedProcess) -> str:
    return f"\n--- stdout\n{r.stdout[-3000:]}\n--- stderr\n{r.stderr[-3000:]}"


def _check(command: dc.Command, r: subprocess.CompletedProcess) -> None:
    assert r.returncode == 0, f"{command.where}: `{command.text}` exited with {r.returncode}{_said(r)}"
    bench = _BENCH.match(command.key)
    if bench and BENCH[bench.group(1)] == "skips":
        assert any(ln.startswith("skipped:") and "not here" in ln for ln in r.stdout.splitlines()), \
            f"{command.where}: `{command.text}` did not say it skipped{_said(r)}"
    for shown in command.output:      # a console block's output: each line's first field
        first = shown.split("\t")[0]
        assert any(ln.split("\t")[0] == first for ln in r.stdout.splitlines()), \
            f"{command.where}: `{command.text}` printed no line for {first!r}{_said(r)}"


def how(command: dc.Command) -> str:
    """"blender", "mapped", "slow" or "run": how the tests cover the command."""
    if dc.is_blender_command(command.text):
        return "blender"
    if command.key in MAPPED:
        return "mapped"
    bench = _BENCH.match(command.key)
    if command.key in SLOW or (bench and BENCH.get(bench.group(1)) == "slow"):
        return "slow"
    return "run"


COMMANDS = dc.all_commands()
RUN_BLOCKS = [b for b in dc.all_blocks() if any(how(c) == "run" for c in b.commands())]


# --- the tests ----------------------------------------------------------------------

@pytest.mark.parametrize("block", RUN_BLOCKS, ids=[f"{b.page}:{b.line}" for b in RUN_BLOCKS])
def test_commands_run(block, tmp_path):
    commands = [c for c in block.commands() if how(c) == "run"]
    box = _box(tmp_path, block.page, commands)
    for command in commands:
        _check(command, _run(command, box))


PYTHON_BLOCKS = dc.python_blocks()


@pytest.mark.parametrize("block", PYTHON_BLOCKS, ids=[f"{b.page}:{b.line}" for b in PYTHON_BLOCKS])
def test_python_blocks_run(block, tmp_path):
    program = "\n".join(block.body) + "\n"
    box = _box(tmp_path, block.page, [dc.Command(block.page, block.line + 1, program)])
    (box / "program.py").write_text(program, encoding="utf-8")
    command = dc.Command(block.page, block.line + 1, ".venv/bin/python program.py")
    _check(command, _run(command, box))


SLOW_COMMANDS = [c for c in COMMANDS if how(c) == "slow"]


@pytest.mark.skipif(not SLOW_TESTS, reason=SLOW_REASON)
@pytest.mark.parametrize("command", SLOW_COMMANDS, ids=[f"{c.where} {c.key}" for c in SLOW_COMMANDS])
def test_slow_commands_run(command, tmp_path):
    """In a copy of the repository (its tracked files as they are in the
    working tree, the environments linked), so that what they write stays
    there; the sample head's assets come from the repository's cache."""
    copy = tmp_path / "repo"
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True)
    for rel in filter(None, listed.stdout.split("\0")):
        if (ROOT / rel).is_file():
            (copy / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / rel, copy / rel)
    for venv in ROOT.glob(".venv*"):
        (copy / venv.name).symlink_to(venv)
    (copy / "out").mkdir()
    env = dict(os.environ, LIPSYNC_DATA=str(tmp_path / "no-recordings-here"),
               EMOTIVE_LIPSYNC_ASSETS=os.environ.get("EMOTIVE_LIPSYNC_ASSETS", str(ROOT / "build" / "assets")))
    r = subprocess.run(["bash", "-c", command.text], cwd=copy, env=env, capture_output=True, text=True, timeout=3600)
    _check(command, r)


def test_every_command_is_covered():
    """Each command is run here, run by the Blender tests, mapped, or slow;
    every benchmark says what it does without the recordings; the registries
    name only commands the pages show."""
    keys = {c.key for c in COMMANDS}
    assert set(MAPPED) <= keys, f"MAPPED names commands no page shows: {sorted(set(MAPPED) - keys)}"
    assert set(SLOW) <= keys, f"SLOW names commands no page shows: {sorted(set(SLOW) - keys)}"
    for c in COMMANDS:
        bench = _BENCH.match(c.key)
        if bench:
            assert bench.group(1) in BENCH, f"{c.where}: say in BENCH what bench/{bench.group(1)}.py does without " \
                                            "../shared/data"
        if dc.is_blender_command(c.text):
            dc.blender_argv(c.text)     # a form the Blender test can run
    assert {how(c) for c in COMMANDS} <= {"blender", "mapped", "slow", "run"}


def _function_source(path: Path, name: str) -> str | None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name == name:
            return ast.get_source_segment(path.read_text(encoding="utf-8"), node)
    return None


@pytest.mark.parametrize("command", sorted(MAPPED), ids=[k.split(" \"")[0] for k in sorted(MAPPED)])
def test_mapped_commands_are_run_by_the_test_named(command):
    target, evidence = MAPPED[command]
    path, _, name = target.partition("::")
    assert (ROOT / path).is_file(), f"{command}: {path} does not exist"
    source = _function_source(ROOT / path, name) if name else (ROOT / path).read_text(encoding="utf-8")
    assert source is not None, f"{command}: {path} has no {name}"
    for text in evidence:
        assert text in source, f"{command}: {target} does not hold {text!r}"


def test_blender_commands_are_run_by_the_blender_tests():
    """tests/blender/test_docs_commands.py runs every `blender --command lipsync` line the pages show."""
    blender = dc.blender_commands()
    assert len(blender) >= 6
    source = _function_source(ROOT / "tests" / "blender" / "test_docs_commands.py", "test_documented_command")
    assert source is not None
    assert "doccommands.blender_commands()" in (ROOT / "tests" / "blender" / "test_docs_commands.py").read_text()


def _synopses() -> list[tuple[str, str, str]]:
    """(where, subcommand, text) of every `python -m addon SUB ...` usage
    synopsis: a ```text block's line and the indented lines after it."""
    out = []
    for b in dc.all_blocks():
        if b.lang != "text":
            continue
        for k, line in enumerate(b.body):
            m = re.match(r"\.venv/bin/python -m addon (\w+)", line)
            if m:
                more = []
                for ln in b.body[k + 1:]:
                    if not ln.startswith(" "):
                        break
                    more.append(ln)
                out.append((f"{b.page}:{b.line + 1 + k}", m.group(1), " ".join([line] + more)))
    return out


def test_synopses_name_only_options_the_commands_have():
    from addon.engine.cli import _parser

    parser = _parser()
    subparsers = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    found = _synopses()
    assert {sub for _w, sub, _t in found} >= {"analyze", "batch"}
    for where, sub, text in found:
        assert sub in subparsers.choices, f"{where}: no command {sub!r}"
        options = {s for a in subparsers.choices[sub]._actions for s in a.option_strings}
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", text))
        assert named <= options, f"{where}: `{sub}` has no option {sorted(named - options)}"


def _slug(heading: str) -> str:
    """A heading's anchor as GitHub makes it."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _prose(path: Path) -> str:
    return re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.S | re.M)


def test_links_between_the_pages_resolve():
    bad = []
    for page in dc.pages():
        for m in re.finditer(r"\]\(([^)\s]+)\)", _prose(page)):
            target = m.group(1)
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page.resolve()
            if not dest.exists():
                bad.append(f"{page.name}: {target} (no such file)")
            elif anchor and dest.suffix == ".md":
                anchors = {_slug(h) for h in re.findall(r"^#+\s+(.*)$", _prose(dest), re.M)}
                if anchor not in anchors:
                    bad.append(f"{page.name}: {target} (no such heading)")
    assert not bad, "\n".join(bad)


def test_every_page_of_the_guide_is_in_its_index():
    index = (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for page in sorted((ROOT / "docs").glob("*.md")):
        if page.name != "README.md":
            assert f"]({page.name})" in index, f"docs/README.md does not link {page.name}"
            assert f"](docs/{page.name}" in readme, f"README.md does not link docs/{page.name}"


def test_the_readme_starts_with_the_two_commands_and_stays_short():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    first = dc.blocks(ROOT / "README.md")[0]
    assert [c.key for c in first.commands()] == ["./setup.sh", "./test.sh"]
    assert first.line < 20
    assert len(readme.splitlines()) <= 200


def test_the_pages_file_blocks_are_what_they_say():
    """A declared JSON file parses; a declared manifest has a header the batch reads."""
    for page in dc.pages():
        for name, content in dc.files(page.relative_to(ROOT).as_posix()).items():
            if name.endswith(".json"):
                json.loads(content)
            elif name.endswith(".csv"):
                assert content.splitlines()[0].startswith("audio,"), f"{page.name}: {name}"
