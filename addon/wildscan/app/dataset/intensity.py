"""A dataset scan's intensity (SPEC.toml `intensity`, core/realism/intensity.py): set on the cloud
before any format encodes it, so PLY, LAS and SemanticKITTI carry the same number.

`physical` needs each point's incidence: a paper scan run with `incidence=True` has it, from
the normals of the sweep's own hits (core/scan.py ScanResult.incidence; a sward's or a weather
particle's point faces its beam: cos θ = 1); the realistic model's echo energy already holds
cos θ and the footprint's coverage, which are kept, its class reflectivity swapped for the
surface's own and its range law for R_NEAR's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...core.realism import intensity as I
from ...core.realism.echoes import R_REF
from ...core.truth.groundtruth import world_points


def with_dataset_intensity(mode: str, seed: int, scan: int, result, world=None):
    """`result` (core/scan.py ScanResult) with its cloud's intensity in `mode`, percent, and
    its metadata saying which (the PLY header and sidecar, LAS's description carry it).
    `world`: the cloud's points in the world frame, when the caller has them already."""
    cloud = result.cloud
    if mode == "class":
        value = I.class_percent(cloud.label)
    else:
        value = _physical(seed, scan, result, world)
    return replace(
        result,
        cloud=replace(cloud, intensity=value.astype(np.float32)),
        metadata=dict(result.metadata, intensity=mode),
    )


def _physical(seed: int, scan: int, result, world=None) -> np.ndarray:
    cloud, placement = result.cloud, result.placement
    if world is None:
        world = world_points(cloud.xyz, placement, cloud.frame)
    rho = I.surface_reflectance(seed, cloud.label, cloud.instance, world[:, :2])
    distance = cloud.range.astype(np.float64)
    if "echo" in cloud.extra:
        coverage = _realistic_coverage(cloud.intensity, cloud.label, distance)
    else:
        coverage = _incidence(result)
    return I.physical_percent(rho, coverage, distance, I.speckle(seed, scan, len(cloud)))


def _realistic_coverage(energy: np.ndarray, label: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """Σ w_k cos θ_k of a realistic echo (core/realism/echoes.py: e = Σ w ρ cos θ (R_REF/R)², ρ its
    class's Table I value): the energy without its class reflectivity and range law."""
    table = I.class_percent(label)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = energy.astype(np.float64) * (distance / R_REF) ** 2 / table
    return np.clip(np.nan_to_num(cos, nan=1.0, posinf=1.0), 0.0, 1.0)


def _incidence(result) -> np.ndarray:
    """|cos θ| of each point of a paper scan: the sweep's own (run_scan(..., incidence=True))."""
    if result.incidence is None:
        raise ValueError("a paper scan's physical intensity needs run_scan(..., incidence=True)")
    return result.incidence


def scan_intensity_facts(cloud) -> dict:
    """The manifest row's remission histogram by class (the card's lookup accuracy)."""
    return {"remission_histogram": I.remission_histogram(cloud.intensity / 100.0, cloud.label)}


LOOKUP_WARNING = 0.9  # above this, a network fed remission can learn the lookup instead of the shapes


def remission_totals(rows: list[dict]) -> dict:
    """The lookup accuracy of remission alone over the scans written (rows with a histogram)."""
    rows = [r for r in rows if "remission_histogram" in r]
    if not rows:
        return {}
    total: dict[str, list[int]] = {}
    for r in rows:
        I.add_histograms(total, r["remission_histogram"])
    return {
        "remission_lookup_accuracy": I.lookup_accuracy(total),
        "remission_lookup_balanced": I.balanced_lookup_accuracy(total),
        "majority_class_share": I.majority_share(total),
    }


def intensity_lines(spec, t: dict) -> list[str]:
    """The card's line on what intensity is and how much it says about the label."""
    if t.get("remission_lookup_accuracy") is None:
        return []
    accuracy = t["remission_lookup_accuracy"]
    what = {
        "physical": "physical (surface reflectance, incidence and range; docs/formats.md)",
        "class": "class (the paper's tag: each class's Table I reflectivity)",
    }[spec.intensity]
    line = (
        f"Intensity: {what}. Remission alone labels {100 * accuracy:.1f} % of points "
        "(each 0.01 of remission predicting its most common class; answering the commonest class "
        f"everywhere labels {100 * t['majority_class_share']:.1f} %); its recall averaged over the "
        f"classes is {100 * t['remission_lookup_balanced']:.1f} %."
    )
    if accuracy > LOOKUP_WARNING:
        line += (
            f" **Warning: above {100 * LOOKUP_WARNING:.0f} %: a network fed remission can learn this lookup "
            'instead of shapes; use intensity = "physical" or leave remission out.**'
        )
    return [line]
