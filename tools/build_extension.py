"""Build the Blender extension: one validated zip per platform.

    .venv/bin/python tools/build_extension.py [--platform linux-x64 ...] [--output-dir dist]

The wheels listed in ``blender_manifest.toml`` are downloaded once into
``build/wheels`` (never committed), the package is staged in
``build/stage`` (the ``addon`` package at the zip's root, beside the manifest
and the wheels), and Blender's own extension tool, which ships inside the
``bpy`` wheel (``addons_core/bl_pkg/cli/blender_ext.py``), builds and then
validates each zip.  No Blender binary is needed.
"""

from __future__ import annotations

import argparse
import glob
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BUILD = ROOT / "build"
WHEELS = BUILD / "wheels"
STAGE = BUILD / "stage"

# Wheel platform tag -> extension platforms it serves.
_TAG_PLATFORMS = (
    ("manylinux", "x86_64", ("linux-x64",)),
    ("win_amd64", "", ("windows-x64",)),
    ("macosx", "universal2", ("macos-arm64", "macos-x64")),
    ("macosx", "arm64", ("macos-arm64",)),
    ("macosx", "x86_64", ("macos-x64",)),
)


def wheel_platforms(filename: str) -> tuple[str, ...]:
    tag = filename[:-len(".whl")].split("-")[-1]
    for head, tail, platforms in _TAG_PLATFORMS:
        if tag.startswith(head) and tag.endswith(tail):
            return platforms
    raise SystemExit(f"build: cannot tell the platform of wheel {filename}")


def blender_ext() -> Path:
    found = glob.glob(str(Path(sys.prefix) / "lib" / "python*" / "site-packages" / "bpy" / "*" / "scripts"
                          / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"))
    if not found:
        raise SystemExit("build: Blender's extension tool was not found; install the bpy wheel "
                         "(./setup.sh does) and run this with .venv/bin/python")
    return Path(found[0])


def download(filename: str) -> Path:
    """Fetch one pinned wheel from the package index by its exact file name."""
    target = WHEELS / filename
    if target.is_file():
        return target
    WHEELS.mkdir(parents=True, exist_ok=True)
    name, version, py, abi, tag = filename[:-len(".whl")].split("-")
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary", ":all:",
           "--dest", str(WHEELS), "--python-version", py[2:3] + "." + py[3:], "--implementation", "cp",
           "--abi", abi, f"{name.replace('_', '-')}=={version}"]
    for t in tag.split("."):
        cmd += ["--platform", t]
    subprocess.run(cmd, check=True)
    if not target.is_file():
        raise SystemExit(f"build: pip did not produce {filename}; is the manifest's wheel name right?")
    return target


def stage(manifest_text: str, platforms: list[str], wheels: list[str]) -> None:
    if STAGE.exists():
        shutil.rmtree(STAGE)
    shutil.copytree(ROOT / "addon", STAGE, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (STAGE / "wheels").mkdir()
    for w in wheels:
        shutil.copy2(WHEELS / w, STAGE / "wheels" / w)
    text = re.sub(r"(?ms)^platforms = \[.*?\]", "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]",
                  manifest_text)
    text = re.sub(r"(?ms)^wheels = \[.*?\n\]", "wheels = [\n" + "".join(f'  "./wheels/{w}",\n' for w in wheels)
                  + "]", text)
    (STAGE / "blender_manifest.toml").write_text(text, encoding="utf-8")


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
    wheels = [Path(w).name for w in manifest["wheels"]
              if set(wheel_platforms(Path(w).name)) & set(platforms)]
    for w in wheels:
        download(w)
    stage(text, platforms, wheels)

    tool = blender_ext()
    out = Path(args.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    subprocess.run([sys.executable, str(tool), "build", "--split-platforms", "--source-dir", str(STAGE),
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
