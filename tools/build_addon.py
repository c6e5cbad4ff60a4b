#!/usr/bin/env python3
"""Build the two installable zips of the WildScan Blender add-on (`make addon`).

  dist/wildscan-<version>-legacy.zip     Blender 3.4 and later, as a legacy add-on:
                                         the package folder `wildscan/` at the zip root
                                         (its __init__.py carries bl_info).
  dist/wildscan-<version>-extension.zip  Blender 4.2 and later, as an extension:
                                         blender_manifest.toml and __init__.py at the zip
                                         root (Blender's extension layout).

The legacy zip leaves blender_manifest.toml out so that Blender 4.2+ treats it as
the legacy add-on it is. Zips are reproducible: sorted entries, fixed timestamps.

Usage: python tools/build_addon.py [--out DIR]
"""

from __future__ import annotations

import argparse
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "addon" / "wildscan"
MANIFEST = "blender_manifest.toml"
SKIP_DIRS = {"__pycache__", ".pytest_cache", ".ruff_cache"}
SKIP_SUFFIXES = {".pyc", ".pyo", ".orig", ".rej", ".swp"}
FIXED_TIME = (2024, 1, 1, 0, 0, 0)  # zip timestamps, so the same sources give the same bytes


class BuildError(Exception):
    pass


def package_version(package: Path = PACKAGE) -> str:
    text = (package / "__init__.py").read_text(encoding="utf-8")
    match = re.search(r'^__version__\s*=\s*["\']([^"\']+)["\']', text, re.MULTILINE)
    if match is None:
        raise BuildError(f"{package / '__init__.py'} defines no __version__")
    return match.group(1)


def check_manifest(package: Path, version: str) -> dict:
    """The manifest, checked against what Blender 4.2+ requires and the package version."""
    path = package / MANIFEST
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BuildError(f"{path} is missing") from None
    try:
        import tomllib
    except ImportError:  # Python 3.10: read the top-level `key = "value"` lines only
        manifest = dict(re.findall(r'^(\w+)\s*=\s*"([^"]*)"', text, re.MULTILINE))
        manifest.setdefault("license", [])
    else:
        try:
            manifest = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise BuildError(f"{path} is not valid TOML: {e}") from None
    required = (
        "schema_version",
        "id",
        "version",
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
    if manifest["version"] != version:
        raise BuildError(f"{path} says version {manifest['version']} but the package is {version}")
    if manifest["type"] != "add-on":
        raise BuildError(f"{path}: type must be 'add-on', got {manifest['type']!r}")
    return manifest


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


def write_zip(out: Path, entries: list[tuple[str, Path]]) -> Path:
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for arcname, path in entries:
            info = zipfile.ZipInfo(arcname, date_time=FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, path.read_bytes())
    tmp.replace(out)
    return out


def build(out_dir: Path = ROOT / "dist", package: Path = PACKAGE) -> tuple[Path, Path]:
    """Build both zips into `out_dir`; returns (legacy zip, extension zip)."""
    version = package_version(package)
    check_bl_info(package)
    check_manifest(package, version)
    files = package_files(package)
    legacy = [(f"wildscan/{p.relative_to(package).as_posix()}", p) for p in files if p.name != MANIFEST]
    extension = [(p.relative_to(package).as_posix(), p) for p in files]
    return (
        write_zip(out_dir / f"wildscan-{version}-legacy.zip", legacy),
        write_zip(out_dir / f"wildscan-{version}-extension.zip", extension),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Build the WildScan add-on zips (legacy and 4.2+ extension)."
    )
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="output directory (default dist/)")
    args = parser.parse_args(argv)
    try:
        for path in build(args.out):
            print(f"wrote {path}")
    except BuildError as e:
        print(f"build_addon: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
