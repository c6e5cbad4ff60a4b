#!/usr/bin/env python3
"""Build the two installable zips of the WildScan Blender add-on (`make addon`).

  dist/wildscan-<version>-legacy.zip     Blender 3.4 and later, as a legacy add-on:
                                         the package folder `wildscan/` at the zip root
                                         (its __init__.py carries bl_info).
  dist/wildscan-<version>-extension.zip  Blender 4.2 and later, as an extension:
                                         blender_manifest.toml and __init__.py at the zip
                                         root (Blender's extension layout), and the
                                         `embreex` wheels in wheels/.

The version comes from bl_info in addon/wildscan/__init__.py (its one source) and is
written into the zipped blender_manifest.toml, with the `wheels` list.

The fast ray caster inside Blender: Blender's Python has no `embreex`, so the add-on
would fall back to the slower BVH. The extension bundles the embreex wheels of every
platform it has a wheel for, for the Python that Blender 4.2-5.0 ship (3.11), as
Blender's extension docs ask (unmodified wheels from PyPI under ./wheels/, listed in
the manifest's `wheels`); Blender installs the one for its platform when the
extension is enabled. No `platforms` list: the add-on itself is pure Python and runs
anywhere, a platform without a wheel (Linux on ARM: embreex publishes none) uses the
BVH. The wheels are downloaded at build time with pip into a cache (dist/wheels/),
never committed; embreex's one dependency, numpy, ships with Blender.
The legacy zip (Blender 3.4-4.1, which cannot install wheels) bundles none and keeps
the BVH fallback and its notice.

The legacy zip leaves blender_manifest.toml out so that Blender 4.2+ treats it as
the legacy add-on it is. Zips are reproducible: sorted entries, fixed timestamps.

Usage: python tools/build_addon.py [--out DIR] [--wheel-cache DIR]
"""

from __future__ import annotations

import argparse
import ast
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "addon" / "wildscan"
MANIFEST = "blender_manifest.toml"
SKIP_DIRS = {"__pycache__", ".pytest_cache", ".ruff_cache"}
SKIP_SUFFIXES = {".pyc", ".pyo", ".orig", ".rej", ".swp"}
FIXED_TIME = (2024, 1, 1, 0, 0, 0)  # zip timestamps, so the same sources give the same bytes
WHEEL_CACHE = ROOT / "dist" / "wheels"

# The fast ray caster bundled into the extension, for Blender 4.2-5.0's Python.
EMBREEX = "embreex"
EMBREEX_VERSION = "4.4.0.post1"
BLENDER_PYTHON = "3.11"
# Blender platform -> the pip --platform tag to fetch (pip also takes older compatible
# tags: the Linux wheel is manylinux_2_27/2_28, the macOS ones macosx_13_0).
# Linux ARM64 is missing on purpose: embreex publishes no aarch64 wheel.
WHEEL_PLATFORMS = {
    "linux-x64": "manylinux_2_28_x86_64",
    "windows-x64": "win_amd64",
    "macos-x64": "macosx_13_0_x86_64",
    "macos-arm64": "macosx_13_0_arm64",
}
# Generated into the zipped manifest, never written in the source one.
GENERATED_KEYS = ("version", "wheels")


class BuildError(Exception):
    pass


def package_version(package: Path = PACKAGE) -> str:
    """The version, from bl_info["version"] in the package's __init__.py (read, not imported)."""
    path = package / "__init__.py"
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "bl_info" for t in node.targets):
            try:
                version = ast.literal_eval(node.value)["version"]
            except (ValueError, KeyError, TypeError):
                raise BuildError(f"{path}: bl_info must be a literal dict with a 'version' tuple") from None
            if not (isinstance(version, tuple) and version and all(isinstance(v, int) for v in version)):
                raise BuildError(f"{path}: bl_info['version'] must be a tuple of ints, got {version!r}")
            return ".".join(str(v) for v in version)
    raise BuildError(f"{path} has no bl_info: Blender before 4.2 could not install it")


def parse_manifest(text: str, path) -> dict:
    try:
        import tomllib
    except ImportError:  # Python 3.10: read the top-level `key = "value"` lines and lists of strings
        manifest: dict = dict(re.findall(r'^(\w+)\s*=\s*"([^"]*)"', text, re.MULTILINE))
        for key, body in re.findall(r"^(\w+)\s*=\s*\[(.*?)\]", text, re.MULTILINE | re.DOTALL):
            manifest[key] = re.findall(r'"([^"]*)"', body)
        return manifest
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise BuildError(f"{path} is not valid TOML: {e}") from None


def check_manifest(package: Path) -> str:
    """The source manifest's text, checked against what Blender 4.2+ requires; it must
    leave `version` and `wheels` to the build."""
    path = package / MANIFEST
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BuildError(f"{path} is missing") from None
    manifest = parse_manifest(text, path)
    required = (
        "schema_version",
        "id",
        "name",
        "tagline",
        "maintainer",
        "type",
        "blender_version_min",
        "license",
    )
    missing = [key for key in required if key not in manifest]
    if missing:
        raise BuildError(f"{path} lacks {', '.join(missing)}")
    written = [key for key in GENERATED_KEYS if key in manifest]
    if written:
        raise BuildError(
            f"{path} sets {', '.join(written)}: the build writes them (the version from bl_info in "
            "__init__.py, its one source); remove them"
        )
    if manifest["type"] != "add-on":
        raise BuildError(f"{path}: type must be 'add-on', got {manifest['type']!r}")
    return text


def extension_manifest(text: str, version: str, wheels: list[str]) -> str:
    """The source manifest with `version` after `id` and the `wheels` list before the
    first table (top-level keys must come before it in TOML)."""
    lines = text.splitlines()
    at_id = next(i for i, line in enumerate(lines) if re.match(r"\s*id\s*=", line))
    lines.insert(at_id + 1, f'version = "{version}"')
    table = next((i for i, line in enumerate(lines) if line.startswith("[")), len(lines))
    block = ["wheels = ["] + [f'  "{w}",' for w in wheels] + ["]", ""] if wheels else []
    lines[table:table] = block
    out = "\n".join(lines) + "\n"
    manifest = parse_manifest(out, "the generated manifest")
    if manifest.get("version") != version or list(manifest.get("wheels", [])) != list(wheels):
        raise BuildError("internal error: the generated manifest does not say what was written into it")
    return out


def check_bl_info(package: Path) -> None:
    text = (package / "__init__.py").read_text(encoding="utf-8")
    if not re.search(r"^bl_info\s*=", text, re.MULTILINE):
        raise BuildError(f"{package / '__init__.py'} has no bl_info: Blender before 4.2 could not install it")


def package_files(package: Path) -> list[Path]:
    """Every file of the package that belongs in an add-on, sorted."""
    files = []
    for path in sorted(package.rglob("*")):
        rel = path.relative_to(package)
        if path.is_dir() or any(part in SKIP_DIRS or part.endswith(".egg-info") for part in rel.parts):
            continue
        if path.suffix in SKIP_SUFFIXES or path.name.startswith("."):
            continue
        files.append(path)
    return files


# ---------------------------------------------------------------------------------------
# the embreex wheels


def fetch_wheels(cache: Path = WHEEL_CACHE, platforms: dict[str, str] = WHEEL_PLATFORMS) -> list[Path]:
    """One embreex wheel per Blender platform, from the cache or else downloaded with pip
    (unmodified, binary only, no dependencies) into cache/<platform>/; sorted by name."""
    return sorted((_cached_wheel(cache / platform, tag) for platform, tag in platforms.items()), key=str)


def _cached_wheel(directory: Path, pip_platform: str) -> Path:
    prefix = f"{EMBREEX}-{EMBREEX_VERSION}-cp{BLENDER_PYTHON.replace('.', '')}-"
    found = sorted(directory.glob(f"{prefix}*.whl")) if directory.is_dir() else []
    if len(found) == 1:
        return found[0]
    directory.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        command = [
            sys.executable,
            "-m",
            "pip",
            "download",
            f"{EMBREEX}=={EMBREEX_VERSION}",
            "--no-deps",
            "--only-binary=:all:",
            "--platform",
            pip_platform,
            "--python-version",
            BLENDER_PYTHON,
            "--implementation",
            "cp",
            "--dest",
            tmp,
            "--quiet",
            "--disable-pip-version-check",
        ]
        run = subprocess.run(command, capture_output=True, text=True)
        got = sorted(Path(tmp).glob(f"{prefix}*.whl"))
        if run.returncode != 0 or len(got) != 1:
            why = (run.stderr.strip().splitlines() or ["pip gave no wheel"])[-1]
            raise BuildError(
                f"cannot download the {EMBREEX} {EMBREEX_VERSION} wheel for {pip_platform}: {why}"
            )
        for old in found:
            old.unlink()
        return Path(shutil.move(str(got[0]), directory / got[0].name))


# ---------------------------------------------------------------------------------------
# the zips


def write_zip(out: Path, entries: list[tuple[str, Path | bytes]]) -> Path:
    """A reproducible zip of (name, file or bytes); wheels are stored as they are (they
    are zips already), everything else deflated."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for arcname, source in entries:
            info = zipfile.ZipInfo(arcname, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_STORED if arcname.endswith(".whl") else zipfile.ZIP_DEFLATED
            info.create_system = 3
            info.external_attr = 0o644 << 16
            zf.writestr(info, source if isinstance(source, bytes) else source.read_bytes())
    tmp.replace(out)
    return out


def build(
    out_dir: Path = ROOT / "dist", package: Path = PACKAGE, wheel_cache: Path = WHEEL_CACHE
) -> tuple[Path, Path]:
    """Build both zips into `out_dir`; returns (legacy zip, extension zip)."""
    version = package_version(package)
    check_bl_info(package)
    manifest_text = check_manifest(package)
    wheels = fetch_wheels(wheel_cache)
    files = package_files(package)
    legacy = [(f"wildscan/{p.relative_to(package).as_posix()}", p) for p in files if p.name != MANIFEST]
    listed = [f"./wheels/{w.name}" for w in wheels]
    manifest = extension_manifest(manifest_text, version, listed)
    extension: list[tuple[str, Path | bytes]] = [
        (p.relative_to(package).as_posix(), p) for p in files if p.name != MANIFEST
    ]
    extension.append((MANIFEST, manifest.encode("utf-8")))
    extension += [(f"wheels/{w.name}", w) for w in wheels]
    return (
        write_zip(out_dir / f"wildscan-{version}-legacy.zip", legacy),
        write_zip(out_dir / f"wildscan-{version}-extension.zip", sorted(extension)),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Build the WildScan add-on zips (legacy and 4.2+ extension with the embreex wheels)."
    )
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="output directory (default dist/)")
    parser.add_argument(
        "--wheel-cache",
        type=Path,
        default=WHEEL_CACHE,
        help="where downloaded wheels are kept between builds (default dist/wheels/)",
    )
    args = parser.parse_args(argv)
    try:
        for path in build(args.out, wheel_cache=args.wheel_cache):
            print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    except BuildError as e:
        print(f"build_addon: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
