"""Build the Blender extension: one validated zip per platform.

    .venv/bin/python tools/build_extension.py [--platform linux-x64 ...] [--output-dir dist]

The wheels listed in ``blender_manifest.toml`` (parselmouth and
pocketsphinx, for Python 3.11 and 3.13; espeakng-loader, pykakasi and
jaconv, for any Python 3) are downloaded once into
``build/wheels`` (never committed).  Each run stages the package in a
temporary folder of its own (the ``addon`` package at the zip's root, beside
the manifest and the wheels), so several builds may run at once, and
Blender's own extension tool, which ships inside the ``bpy`` wheel
(``addons_core/bl_pkg/cli/blender_ext.py``), builds and then validates each
zip.  No Blender binary is needed.

Wheels for Python 3.13 are staged under a name with a build tag
(``pocketsphinx-5.1.1-1-cp313-cp313-...whl``; the file itself is PyPI's).
Blender 4.2.13 and later install only the wheels matching their Python, but
the first 4.2 releases filter by platform only and, of two wheels of one
package and version, install the one whose file name sorts last
(``wheel_list_deduplicate_as_skip_set`` in ``_bpy_internal/extensions/
wheel_manager.py``): that would be ``cp313`` on their Python 3.11.  With the
build tag the ``cp311`` name sorts last ("c" > "1").
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BUILD = ROOT / "build"
WHEELS = BUILD / "wheels"

#: Python tags whose wheels get :data:`BUILD_TAG` when staged (see above).
BUILD_TAGGED = ("cp313",)
BUILD_TAG = "1"

#: Every platform an extension can name; a pure-Python wheel ("any") serves them all.
ALL_PLATFORMS = ("linux-x64", "windows-x64", "macos-arm64", "macos-x64")

# Wheel platform tag -> extension platforms it serves.
_TAG_PLATFORMS = (
    ("any", "", ALL_PLATFORMS),
    ("manylinux", "x86_64", ("linux-x64",)),
    ("win_amd64", "", ("windows-x64",)),
    ("macosx", "universal2", ("macos-arm64", "macos-x64")),
    ("macosx", "arm64", ("macos-arm64",)),
    ("macosx", "x86_64", ("macos-x64",)),
)


def wheel_tags(filename: str) -> tuple[str, str, str, str, str]:
    """(distribution, version, python tag, abi tag, platform tag) of a wheel
    file name, with or without a build tag."""
    parts = filename[:-len(".whl")].split("-")
    if not filename.endswith(".whl") or len(parts) not in (5, 6):
        raise SystemExit(f"build: {filename} is not a wheel file name")
    return parts[0], parts[1], parts[-3], parts[-2], parts[-1]


def wheel_platforms(filename: str) -> tuple[str, ...]:
    tag = wheel_tags(filename)[4]
    for head, tail, platforms in _TAG_PLATFORMS:
        if tag.startswith(head) and tag.endswith(tail):
            return platforms
    raise SystemExit(f"build: cannot tell the platform of wheel {filename}")


def staged_name(filename: str) -> str:
    """The name a downloaded wheel has inside the zip."""
    name, version, py, abi, tag = wheel_tags(filename)
    if py in BUILD_TAGGED:
        return "-".join((name, version, BUILD_TAG, py, abi, tag)) + ".whl"
    return filename


def for_any_python(filename: str) -> bool:
    """A wheel for every Python 3 (``py3``), not one CPython version."""
    return wheel_tags(filename)[2].startswith("py")


def check_pythons(wheels: list[str], platforms: list[str]) -> None:
    """Every platform gets the same packages for every Python the manifest
    names: a wheel missing for one Python would break the extension on the
    Blender releases using it.  A ``py3`` wheel serves them all."""
    wheels = [w for w in wheels if not for_any_python(w)]
    pythons = sorted({wheel_tags(w)[2] for w in wheels})
    for platform in platforms:
        have = {py: sorted({wheel_tags(w)[0] for w in wheels
                            if wheel_tags(w)[2] == py and platform in wheel_platforms(w)})
                for py in pythons}
        if len({tuple(v) for v in have.values()}) > 1:
            raise SystemExit(f"build: the manifest's wheels for {platform} differ between Pythons: "
                             + "; ".join(f"{py}: {', '.join(v) or 'none'}" for py, v in have.items()))


def blender_ext() -> Path:
    found = glob.glob(str(Path(sys.prefix) / "lib" / "python*" / "site-packages" / "bpy" / "*" / "scripts"
                          / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"))
    if not found:
        raise SystemExit("build: Blender's extension tool was not found; install the bpy wheel "
                         "(./setup.sh does) and run this with .venv/bin/python")
    return Path(found[0])


def download(filename: str) -> Path:
    """Fetch one pinned wheel from the package index by its exact file name.

    pip is asked for exactly the file's tags (Python version, ABI and each
    of its platform tags), so it finds this wheel whatever Python runs the
    build.  The file lands in a private folder first and is then moved into
    the cache, so builds running at once never see half a wheel."""
    target = WHEELS / filename
    if target.is_file():
        return target
    WHEELS.mkdir(parents=True, exist_ok=True)
    name, version, py, abi, tag = wheel_tags(filename)
    # A py3 wheel is asked for as Python 3.11's; a cp311 one by its own version.
    python = "3.11" if for_any_python(filename) else py[2:3] + "." + py[3:]
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary", ":all:",
           "--python-version", python, "--implementation", py[:2], "--abi", abi,
           f"{name.replace('_', '-')}=={version}"]
    for t in tag.split("."):
        cmd += ["--platform", t]
    with tempfile.TemporaryDirectory(dir=WHEELS, prefix=".download-") as tmp:
        subprocess.run(cmd + ["--dest", tmp], check=True)
        got = Path(tmp) / filename
        if not got.is_file():
            raise SystemExit(f"build: pip did not produce {filename} (it fetched "
                             f"{', '.join(os.listdir(tmp)) or 'nothing'}); is the manifest's wheel name right?")
        os.replace(got, target)
    return target


def stage(stage_dir: Path, manifest_text: str, platforms: list[str], wheels: list[str]) -> None:
    shutil.copytree(ROOT / "addon", stage_dir, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (stage_dir / "wheels").mkdir()
    for w in wheels:
        shutil.copy2(WHEELS / w, stage_dir / "wheels" / staged_name(w))
    text = re.sub(r"(?ms)^platforms = \[.*?\]", "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]",
                  manifest_text)
    text = re.sub(r"(?ms)^wheels = \[.*?\n\]", "wheels = [\n"
                  + "".join(f'  "./wheels/{staged_name(w)}",\n' for w in wheels) + "]", text)
    (stage_dir / "blender_manifest.toml").write_text(text, encoding="utf-8")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--platform", action="append", help="build only this platform (repeatable); default: all")
    ap.add_argument("--output-dir", default=str(ROOT / "dist"))
    args = ap.parse_args(argv)

    text = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
    manifest = tomllib.loads(text)
    platforms = args.platform or manifest["platforms"]
    unknown = sorted(set(platforms) - set(manifest["platforms"]))
    if unknown:
        raise SystemExit(f"build: unknown platform {', '.join(unknown)}; the manifest lists "
                         f"{', '.join(manifest['platforms'])}")
    listed = [Path(w).name for w in manifest["wheels"]]
    check_pythons(listed, platforms)
    wheels = [w for w in listed if set(wheel_platforms(w)) & set(platforms)]
    for w in wheels:
        download(w)

    tool = blender_ext()
    out = Path(args.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="emotive-lipsync-stage-") as tmp:
        stage_dir = Path(tmp) / "emotive_lipsync"
        stage(stage_dir, text, platforms, wheels)
        subprocess.run([sys.executable, str(tool), "build", "--split-platforms", "--source-dir", str(stage_dir),
                        "--output-dir", str(out)], check=True)
    stem = f"{manifest['id']}-{manifest['version']}"
    zips = [out / f"{stem}-{p.replace('-', '_')}.zip" for p in platforms]
    for z in zips:
        if not z.is_file():
            raise SystemExit(f"build: expected {z} was not written")
        subprocess.run([sys.executable, str(tool), "validate", str(z)], check=True)
        print(f"built and validated {z.relative_to(ROOT) if z.is_relative_to(ROOT) else z}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
