"""From sub-ray hits to echoes: what the UTM-30LX-EW's receiver makes of one beam (numpy only).

Each sub-ray of a beam (core/footprint.py) carries an equal share of the pulse to the
first surface it meets; leaves, blades and branches are opaque, so a beam reaches
several surfaces only through the gaps of its footprint. What comes back:

Intensity (the energy of a return). A sub-ray k of share w_k that meets a surface of
reflectivity ρ_k (Table I) at range R_k and incidence θ_k returns

    e_k = w_k · ρ_k · cos θ_k · (R_REF / R_k)²,    R_REF = 10 m

the Lambertian extended-target form of the lidar range equation (received power ∝
ρ cos θ / R²; e.g. Kashani et al., "A Review of LIDAR Radiometric Processing", Sensors
15(11), 2015, doi:10.3390/s151128099). So a surface filling the beam head-on at 10 m
reads its Table I reflectivity, half of it at 45° (cos 45° = 0.71 times), a quarter at
20 m. An echo's intensity is the sum of its sub-rays' e_k: intensity no longer names the
class (the label comes from the elements the sub-rays hit). Untagged meshes reflect as
ECHO_REFLECTIVITY_UNLABELED; water reflects nothing back (the beam is deflected).

Echoes. The beam's returns, in range order, split wherever two consecutive ones are
more than `separation` apart (what the pulse resolves); each group is one echo. Its
range is the energy-weighted mean of its returns, each taken where the *beam axis*
meets the plane its sub-ray hit: a footprint on one flat surface then reports exactly
the axis range (the first-order centroid of the stretched pulse), while returns from
different surfaces merge into a range between them — the mixed pixel. Its label is the
class holding most of its energy, `purity` that share, its instance the strongest
sub-ray's of that class. A beam keeps its `max_echoes` strongest echoes.

Whether an echo's point lies on its labeled surface (`mixed` false) is decided in
core/realistic.py against the surfaces along the beam axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..classes import NUM_IDS, REFLECTIVITY_BY_ID, UNLABELED, WATER_ID

R_REF = 10.0  # m: a surface filling the beam head-on at this range reads its Table I reflectivity
ECHO_REFLECTIVITY_UNLABELED = 50.0  # an untagged mesh: a mid grey
COS_FLOOR = 1e-3  # a grazing return keeps this much of its energy (its echo still forms)
# A sub-ray's return is moved to the axis along its own plane only while that plane faces
# the axis within 72 deg (tan <= 3: the move is then at most 3x the footprint's radius);
# a more grazing plane would be extrapolated far past the piece the sub-ray met, so its
# return keeps its own range.
MIN_AXIS_COS = 0.3


def _echo_reflectivity() -> np.ndarray:
    refl = REFLECTIVITY_BY_ID.astype(np.float64).copy()
    refl[UNLABELED.id] = ECHO_REFLECTIVITY_UNLABELED
    refl[WATER_ID] = 0.0
    return refl


ECHO_REFLECTIVITY = _echo_reflectivity()


def return_energy(weight, class_id, cos_incidence, distance, override=None) -> np.ndarray:
    """e = w · ρ · cos θ · (R_REF / R)² for each return (Table I units; see module docstring);
    ρ is the object's `wildscan_reflectivity` where `override` is not nan."""
    refl = ECHO_REFLECTIVITY.take(class_id)  # (a miss's -1 takes the last, as indexing would)
    if override is not None:
        refl = np.where(np.isnan(override), refl, override)
    cos = np.maximum(np.abs(cos_incidence), COS_FLOOR)
    return weight * refl * cos * (R_REF / distance) ** 2


@dataclass
class SubrayReturns:
    """Per sub-ray and beam (S, N; sub-ray 0 the axis): what each sub-ray hit."""

    distance: np.ndarray  # float64 range along the sub-ray (inf: nothing)
    class_id: np.ndarray  # int16
    instance: np.ndarray  # int32
    cos_incidence: np.ndarray  # float64 |n · d| of the hit surface
    axis_cos: np.ndarray  # float64 |n · d_axis|: how squarely the hit plane faces the beam axis
    axis_ratio: np.ndarray  # float64 (n · d_sub) / (n · d_axis): the plane met along the axis
    reflectivity: np.ndarray | None = None  # float32 `wildscan_reflectivity` overrides (nan: none)


@dataclass
class Echoes:
    """One entry per echo, ordered by beam, then range (noise-free)."""

    beam: np.ndarray  # int64 beam index
    range: np.ndarray  # float64 metres along the beam axis
    intensity: np.ndarray  # float64 (Table I units, see module docstring)
    label: np.ndarray  # int16 class holding most of the energy
    purity: np.ndarray  # float64 its share of the energy
    instance: np.ndarray  # int32 the strongest sub-ray's of that class
    # float64 sum of w cos(theta) over its returns: the footprint's share on the surfaces times
    # their incidence (what the detection step weighs: core/realism/lost_returns.py)
    cover: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.beam)

    def subset(self, keep) -> "Echoes":
        return Echoes(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))

    @staticmethod
    def joined(parts: list["Echoes"]) -> "Echoes":
        """The echoes of consecutive blocks of beams, in order."""
        if len(parts) == 1:
            return parts[0]
        return Echoes(*(np.concatenate([getattr(p, f) for p in parts]) for f in Echoes.__dataclass_fields__))


def axis_ranges(returns: SubrayReturns) -> np.ndarray:
    """Each return's range where the beam axis meets the plane it hit (its own range for a
    miss or a plane grazing the axis, see MIN_AXIS_COS)."""
    ok = (returns.axis_cos >= MIN_AXIS_COS) & np.isfinite(returns.axis_ratio)
    return returns.distance * np.where(ok, returns.axis_ratio, 1.0)  # x * 1.0 is x, bit for bit


def form_echoes(returns: SubrayReturns, weights: np.ndarray, separation: float, max_echoes: int) -> Echoes:
    """The echoes of every beam (see the module docstring), at most `max_echoes` a beam."""
    s, n = returns.distance.shape
    valid = np.isfinite(returns.distance) & (returns.class_id >= 0) & (returns.class_id != WATER_ID)
    t = np.where(valid, returns.distance, np.inf)
    ranges = np.where(valid, t, 1.0)
    cos, override = returns.cos_incidence, returns.reflectivity
    energy = return_energy(weights[:, None], returns.class_id, cos, ranges, override)
    columns = {
        "t": t,
        "t_axis": axis_ranges(returns),
        "cls": returns.class_id,
        "inst": returns.instance,
        "energy": np.where(valid, energy, 0.0),
        "cover": np.where(valid, weights[:, None] * np.maximum(np.abs(cos), COS_FLOOR), 0.0),
    }
    # Most beams land whole on one element: one echo, nothing to sort or group. (Rows are
    # sub-rays: reducing over them is elementwise work on contiguous rows.)
    whole = np.logical_and.reduce(valid, axis=0)
    if s > 1:
        with np.errstate(invalid="ignore"):  # inf - inf where a sub-ray met nothing
            whole &= np.maximum.reduce(t, axis=0) - np.minimum.reduce(t, axis=0) <= separation
        for k in range(1, s):
            whole &= (columns["cls"][k] == columns["cls"][0]) & (columns["inst"][k] == columns["inst"][0])
    simple = _whole_beam_echoes(np.flatnonzero(whole), columns)
    rest = np.flatnonzero(~whole & np.logical_or.reduce(valid, axis=0))
    grouped = _grouped_echoes(rest, {k: v[:, rest] for k, v in columns.items()}, separation)
    echoes = _merged(simple, grouped)
    # only a grouped beam has several echoes; with none past max_echoes, nothing to drop
    k = max_echoes
    crowded = len(grouped) > k and bool((grouped.beam[k:] == grouped.beam[:-k]).any())
    return _strongest(echoes, max_echoes) if crowded else echoes


def _whole_beam_echoes(beams: np.ndarray, columns: dict) -> Echoes:
    """One echo for each beam whose sub-rays all met one element within the separation."""
    energy = columns["energy"][:, beams]
    t_axis = columns["t_axis"][:, beams]
    total = np.add.reduce(energy, axis=0)
    first = t_axis[0]
    return Echoes(
        beam=beams.astype(np.int64),
        range=first + np.add.reduce(energy * (t_axis - first), axis=0) / total,
        intensity=total,
        label=columns["cls"][0, beams].astype(np.int16),
        purity=np.ones(len(beams)),
        instance=columns["inst"][0, beams].astype(np.int32),
        cover=np.add.reduce(columns["cover"][:, beams], axis=0),
    )


def _grouped_echoes(beams: np.ndarray, columns: dict, separation: float) -> Echoes:
    """The other beams: their returns sorted by range and split where the gap exceeds the
    separation; `columns` hold these beams' returns, (S, M) sub-ray-major, `t` inf where
    there is none."""
    if not len(beams):
        return _no_echoes()
    s, m = columns["t"].shape
    order = np.argsort(columns["t"].T, axis=1, kind="stable")  # (M, S): each beam's by range
    # each beam's returns in that order, gathered from the sub-ray-major rows in one take
    # (take_along_axis built the same index arrays per column, several times slower)
    at = order * m + np.arange(m)[:, None]
    columns = {k: v.ravel().take(at) for k, v in columns.items()}
    valid = columns["t"] < np.inf
    group = np.zeros(valid.shape, dtype=np.int64)
    with np.errstate(invalid="ignore"):  # inf - inf past the last return
        group[:, 1:] = np.cumsum(np.diff(columns["t"], axis=1) > separation, axis=1)
    flat = np.flatnonzero(valid.ravel())
    row = flat // s
    f = {k: v.ravel()[flat] for k, v in columns.items()}
    grp = group.ravel()[flat]
    starts_mask = np.empty(len(flat), dtype=bool)
    starts_mask[0] = True
    starts_mask[1:] = (row[1:] != row[:-1]) | (grp[1:] != grp[:-1])
    starts = np.flatnonzero(starts_mask)
    echo = np.cumsum(starts_mask) - 1
    return _summarise(f, echo, starts, beams[row[starts]])


def _merged(a: Echoes, b: Echoes) -> Echoes:
    """Two sets of echoes of different beams as one, ordered by beam, then range: what a
    lexsort of both by (beam, range) gives, by ordering each (`a` one echo a beam, in beam
    order; `b` in beam order, its echoes by range almost always already) and merging the
    two runs of beams (a stable sort of two sorted runs is a linear merge)."""
    b = b.subset(_by_beam_then_range(b))
    # where each lands among the other's (the place a stable sort by beam gives it): after
    # the other's echoes of the beams before its own
    beams = int(max(a.beam[-1] if len(a) else -1, b.beam[-1] if len(b) else -1)) + 1
    before_a = np.cumsum(np.bincount(a.beam, minlength=beams))
    before_b = np.cumsum(np.bincount(b.beam, minlength=beams))
    at_a = np.arange(len(a)) + (before_b - np.bincount(b.beam, minlength=beams)).take(a.beam)
    at_b = np.arange(len(b)) + (before_a - np.bincount(a.beam, minlength=beams)).take(b.beam)
    fields = {}
    for name in Echoes.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        out = np.empty(len(a) + len(b), dtype=np.result_type(x, y))
        out[at_a] = x
        out[at_b] = y
        fields[name] = out
    return Echoes(**fields)


def _by_beam_then_range(e: Echoes) -> np.ndarray:
    """The order of a lexsort by (beam, range), found without sorting when the echoes are in
    it already (a beam's groups come in order of their sub-rays' ranges, so their echoes'
    ranges nearly always are)."""
    same_beam = e.beam[1:] == e.beam[:-1]
    in_order = (e.beam[1:] >= e.beam[:-1]).all() and not (same_beam & ~(e.range[1:] >= e.range[:-1])).any()
    if in_order:  # (a nan range fails >= and so is sorted as lexsort sorts it)
        return np.arange(len(e))
    return np.lexsort((e.range, e.beam))


def _no_echoes() -> Echoes:
    return Echoes(
        beam=np.zeros(0, dtype=np.int64),
        range=np.zeros(0),
        intensity=np.zeros(0),
        label=np.zeros(0, dtype=np.int16),
        purity=np.zeros(0),
        instance=np.zeros(0, dtype=np.int32),
        cover=np.zeros(0),
    )


def _summarise(f: dict, echo: np.ndarray, starts: np.ndarray, beam: np.ndarray) -> Echoes:
    """Energy, range, label, purity and instance of each group of returns."""
    count = len(starts)
    energy = np.bincount(echo, f["energy"], count)
    # The weighted mean as the first return's range plus the weighted mean deviation: an
    # echo of returns from one plane reports that range bit for bit (a thin beam's too).
    first = f["t_axis"][starts]
    deviation = np.bincount(echo, f["energy"] * (f["t_axis"] - first[echo]), count)
    rng = first + deviation / energy
    label, purity = _labels(f, echo, starts, energy)
    instance = _instances(f, echo, starts, label)
    return Echoes(
        beam=beam.astype(np.int64),
        range=rng,
        intensity=energy,
        label=label.astype(np.int16),
        purity=np.minimum(purity, 1.0),
        instance=instance.astype(np.int32),
        cover=np.bincount(echo, f["cover"], count),
    )


def _instances(f: dict, echo: np.ndarray, starts: np.ndarray, label: np.ndarray) -> np.ndarray:
    """The instance of each group's labeled class's strongest return (the first of equals): a
    group of one instance has it; only groups of several are scored."""
    inst = f["inst"]
    instance = inst[starts]
    several = np.zeros(len(starts), dtype=bool)
    several[echo[inst != instance[echo]]] = True
    if several.any():
        mine = np.flatnonzero(several[echo])  # their returns, group by group
        group = echo[mine]
        score = np.where(f["cls"][mine] == label[group], f["energy"][mine], -1.0)
        first = np.ones(len(mine), dtype=bool)
        first[1:] = group[1:] != group[:-1]
        best = np.maximum.reduceat(score, np.flatnonzero(first))
        candidates = np.flatnonzero(
            score == np.repeat(best, np.diff(np.append(np.flatnonzero(first), len(mine))))
        )
        first_candidate = np.ones(len(candidates), dtype=bool)
        first_candidate[1:] = group[candidates[1:]] != group[candidates[:-1]]
        instance[np.flatnonzero(several)] = inst[mine[candidates[first_candidate]]]
    return instance


def _labels(f: dict, echo: np.ndarray, starts: np.ndarray, energy: np.ndarray):
    """(the class holding most of each group's energy (the lowest id of equals), its share of
    the energy). A group of one class is that class, share 1 (its sums are the same sums in
    the same order); only groups of several classes (or of no energy) are summed class by
    class."""
    cls = f["cls"].astype(np.int64)
    label = cls[starts]
    purity = np.ones(len(starts))
    several = np.zeros(len(starts), dtype=bool)
    several[echo[cls != label[echo]]] = True
    several |= ~(energy > 0)
    if several.any():
        mixed = np.flatnonzero(several)
        place = np.full(len(starts), -1, dtype=np.int64)
        place[mixed] = np.arange(len(mixed))
        mine = place[echo] >= 0
        by_class = np.bincount(
            place[echo[mine]] * NUM_IDS + cls[mine], f["energy"][mine], len(mixed) * NUM_IDS
        ).reshape(len(mixed), NUM_IDS)
        label[mixed] = np.argmax(by_class, axis=1)
        purity[mixed] = by_class[np.arange(len(mixed)), label[mixed]] / energy[mixed]
    return label, purity


def _strongest(echoes: Echoes, max_echoes: int) -> Echoes:
    """At most `max_echoes` echoes a beam: the strongest, still in range order."""
    per_beam = np.bincount(echoes.beam)
    crowded = per_beam[echoes.beam] > max_echoes
    if not crowded.any():
        return echoes
    idx = np.flatnonzero(crowded)
    order = idx[np.lexsort((-echoes.intensity[idx], echoes.beam[idx]))]
    beams = echoes.beam[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = beams[1:] != beams[:-1]
    start_of = np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))
    rank = np.arange(len(order)) - start_of
    keep = np.ones(len(echoes), dtype=bool)
    keep[order[rank >= max_echoes]] = False
    return echoes.subset(keep)
