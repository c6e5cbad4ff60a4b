"""core/rng: numpy's generator with machine-independent floating-point draws. `uniform` is
numpy's own formula as separate operations (so its numbers are numpy's on this machine,
and worlds kept theirs), the normal draws are standard normal, and a longer ask starts with
the same values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildscan.core.rng import Generator, seeded, stage_rng, ziggurat_normals


def numpy_generator(seed: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(seed))


@pytest.mark.parametrize(
    "args",
    [(), (0.0, 2.5), (-3.0, 7.25), (0.0, 2 * math.pi, 1000), (np.arange(5.0), np.arange(5.0) * 3 + 1)],
)
def test_uniform_is_numpys_uniform_bit_for_bit_here(args):
    ours, theirs = seeded(11), numpy_generator(11)
    for _ in range(3):
        a, b = ours.uniform(*args), theirs.uniform(*args)
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
        assert type(a) is type(b) or (np.ndim(a) == 0 and isinstance(a, float))
    assert ours.integers(1000) == theirs.integers(1000)  # the streams stayed in step
    assert ours.uniform(0.0, 1.0, (3, 4)).shape == (3, 4)
    with pytest.raises(ValueError):
        ours.uniform(2.0, 1.0)  # as numpy: high below low is a mistake


def test_the_other_draws_are_numpys():
    ours, theirs = seeded(5), numpy_generator(5)
    assert ours.permutation(50).tolist() == theirs.permutation(50).tolist()
    assert ours.choice(5, p=[0.1, 0.2, 0.3, 0.2, 0.2]) == theirs.choice(5, p=[0.1, 0.2, 0.3, 0.2, 0.2])
    assert ours.random() == theirs.random()
    assert isinstance(stage_rng(1, "world.trees"), Generator)


def test_normal_draws_follow_the_normal_distribution():
    """Kolmogorov-Smirnov against Phi (math.erf: fine in a test) and the moments, 10^6 draws."""
    z = np.sort(seeded(1).standard_normal(1_000_000))
    phi = np.array([0.5 * (1 + math.erf(v / math.sqrt(2))) for v in z[::97]])
    empirical = (np.arange(len(z))[::97] + 0.5) / len(z)
    assert np.abs(phi - empirical).max() < 1.63 / math.sqrt(len(z))  # KS at the 1 % level
    tail = np.mean(np.abs(z) > 3.6541528853610088)  # the ziggurat's tail beyond R
    assert abs(tail - 2.5803e-4) < 4 * math.sqrt(2.5803e-4 / len(z))
    assert abs(z.mean()) < 0.005 and abs(z.std() - 1) < 0.005
    # quantiles of N(0, 1): 1.96 holds 95 %, 3 holds 99.73 %
    assert abs(np.mean(np.abs(z) < 1.959963984540054) - 0.95) < 0.001
    assert abs(np.mean(np.abs(z) < 3.0) - 0.9973002039367398) < 0.0002
    kurtosis = np.mean(z**4) / np.mean(z**2) ** 2
    assert abs(kurtosis - 3) < 0.03
    n = seeded(2).normal(1.5, 0.25, 200_000)
    assert abs(n.mean() - 1.5) < 0.003 and abs(n.std() - 0.25) < 0.003


def test_a_longer_ask_starts_with_the_same_values():
    short = seeded(9).standard_normal(1001)
    assert np.array_equal(seeded(9).standard_normal(50_000)[:1001], short)
    assert np.array_equal(ziggurat_normals(seeded(9), 7), short[:7])
    assert seeded(9).standard_normal((2, 3)).shape == (2, 3)
    assert isinstance(seeded(9).standard_normal(), float)
