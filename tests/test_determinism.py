"""The same inputs give the same bytes on every machine.

numpy, glibc and OpenBLAS pick their code by CPU at run time, and each can be told to
pick another on this machine: NPY_DISABLE_CPU_FEATURES (numpy's AVX-512, AVX2/FMA, AVX
kernels), GLIBC_TUNABLES (glibc's FMA variants of sin, exp, log, atan...) and
OPENBLAS_CORETYPE. Embree cannot: it reads the CPU itself, so one run goes through QEMU
as older CPUs (Sandy Bridge: AVX without AVX2 or FMA, so SSE2 glibc, AVX numpy and
OpenBLAS, Embree's AVX code with 8-wide BVH and no FMA; Haswell: AVX2 and FMA, no
AVX-512). Each run prints full-precision hashes of a world (every element's float64
vertices unrounded, the terrain grid, the sites), its scan geometry, its world.json, and
the PLY and JSON bytes of scans with noise, in the leveled and world frames
(tests/helpers/determinism_probe.py); every run must print the same. The emulated runs add a
short drive (moving, turning, continuous head, wind, noise) and hash every file
it writes: PLYs raw and deskewed, TUM trajectory, SemanticKITTI poses, both bags.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from tests.helpers.scene_helpers import REPO

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

PROBE = REPO / "tests" / "helpers" / "determinism_probe.py"
AVX512 = "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL"
NATIVE_VARIANTS = {
    "numpy without AVX-512": {"NPY_DISABLE_CPU_FEATURES": AVX512},
    "numpy without AVX2 and FMA": {"NPY_DISABLE_CPU_FEATURES": f"{AVX512} AVX2 FMA3"},
    "numpy without AVX": {"NPY_DISABLE_CPU_FEATURES": f"{AVX512} AVX2 FMA3 AVX F16C"},
    "glibc without FMA and AVX2": {"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA"},
    "all of them, OpenBLAS as Sandy Bridge": {
        "NPY_DISABLE_CPU_FEATURES": f"{AVX512} AVX2 FMA3 AVX F16C",
        "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA",
        "OPENBLAS_CORETYPE": "Sandybridge",
    },
}
# QEMU's oldest CPUs this Python runs on (Nehalem: the interpreter or a wheel needs more
# than SSE4.2 and dies with SIGILL)
EMULATED_CPUS = ("SandyBridge", "Haswell")
# what the probe's drive must have written (and hashed), among its other files
DRIVE_FILES = (
    "raw/000001.ply",
    "deskewed/000001.ply",
    "trajectory.tum",
    "sequences/00/poses.txt",
    "drive.bag",
    "drive_ros2/drive_ros2.mcap",
)


def run_probe(command: list[str], env: dict, *args: str) -> dict:
    result = subprocess.run(
        [*command, str(PROBE), *args],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        cwd=REPO,
        # an emulated CPU runs Python tens of times slower, and slower still on a loaded machine
        timeout=1200,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    return json.loads(result.stdout)


@pytest.fixture(scope="module")
def native() -> dict:
    return run_probe([sys.executable], {})


@pytest.mark.parametrize("variant", sorted(NATIVE_VARIANTS))
def test_worlds_and_scans_are_the_same_bytes_whatever_code_numpy_glibc_and_openblas_pick(native, variant):
    forced = run_probe([sys.executable], NATIVE_VARIANTS[variant])
    assert forced == native, {k: (native[k], forced.get(k)) for k in native if forced.get(k) != native[k]}


def test_the_probe_sees_what_it_should(native):
    """Not vacuous: three zones, two frames, with points, and the whole world hashed."""
    plys = [k for k in native if k.endswith("PLY")]
    assert len(plys) == 6 and all(int(native[k].split()[0]) > 10_000 for k in plys)
    assert {
        "world elements",
        "world terrain grid",
        "world sites and levels",
        "scan geometry",
        "world.json",
    } <= set(native)


# A smaller world (low detail, the forest's scans: every class but the park's) and a drive of
# two coarse 3D scans (r_h = 10 deg) for the emulated runs: QEMU runs this about ten times
# slower than the CPU it emulates on.
EMULATED_PROBE = ("--seed", "1", "--detail", "low", "--zones", "forest", "--drive")


@pytest.fixture(scope="module")
def native_small() -> dict:
    here = run_probe([sys.executable], {}, *EMULATED_PROBE)
    assert {f"drive {name}" for name in DRIVE_FILES} <= set(here)
    return here


@pytest.mark.external
@pytest.mark.parametrize("cpu", EMULATED_CPUS)
def test_the_same_bytes_on_an_emulated_older_cpu(native_small, cpu):
    """qemu-user (apt package qemu-user) runs this venv's Python as `cpu`: Embree then picks
    its code for that CPU too."""
    qemu = shutil.which("qemu-x86_64")
    assert qemu, "qemu-x86_64 not found: apt-get install qemu-user"
    here = native_small
    emulated = run_probe([qemu, "-cpu", cpu, sys.executable], {}, *EMULATED_PROBE)
    assert emulated == here, {k: (here[k], emulated.get(k)) for k in here if emulated.get(k) != here[k]}
