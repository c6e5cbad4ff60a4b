"""A drive's route over a trail network (numpy only): from the trail point nearest a start,
node to node, choosing deterministically at every junction, for a given distance; or out
and back to the start (a loop closure: the second half revisits every place of the first).

A network is a list of polylines (K, 2) whose ends that coincide are junctions (the endless
world's `trail_network`, core/world/endless). At a junction the route takes the trail it
has driven least, then the one that turns least from its heading, then the first listed:
the same network and start give the same route on every machine.
"""

from __future__ import annotations

import numpy as np

from .. import detmath as dm
from ..errors import UserError

ROUTES = ("out", "loop")
NODE_DIGITS = 6  # ends equal to a micrometre are one node (the network's ends are shared exactly)


def check_route(route: str) -> str:
    if route not in ROUTES:
        raise UserError(f"must be one of {', '.join(ROUTES)}, got {route!r}", setting="route", allowed=ROUTES)
    return route


def trail_route(network: list, start_xy, distance: float, route: str = "out", drivable=None) -> np.ndarray:
    """(n, 2) the polyline driven: `distance` metres along the network from the point of it
    nearest `start_xy` (route "out"), or half of it out and the same way back ("loop").
    `drivable(path) -> bool`: whether the robot can drive a trail (asked only of the trails
    the route comes to; default: every one); one it cannot is never taken."""
    check_route(route)
    trails = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p, *_ in network]
    trails = [t for t in trails if len(t) >= 2]
    if not trails or not distance > 0:
        raise UserError("has no trail to follow here", setting="trail")
    out = distance / 2 if route == "loop" else distance
    walk = _walk(trails, np.asarray(start_xy, dtype=np.float64)[:2], out, _Drivable(trails, drivable))
    if route == "loop":
        walk = np.concatenate([walk, walk[-2::-1]])
    return walk


class _Drivable:
    """Whether each trail can be driven, asked once a trail."""

    def __init__(self, trails: list[np.ndarray], test):
        self.trails, self.test, self.known = trails, test, {}

    def __call__(self, i: int) -> bool:
        if self.test is None:
            return True
        if i not in self.known:
            self.known[i] = bool(self.test(self.trails[i]))
        return self.known[i]


def _walk(trails: list[np.ndarray], start: np.ndarray, distance: float, drivable: _Drivable) -> np.ndarray:
    """`distance` metres from the network's drivable point nearest `start`, node to node."""
    nodes: dict[tuple, list[tuple[int, int]]] = {}
    for i, t in enumerate(trails):
        nodes.setdefault(_key(t[0]), []).append((i, 1))  # leaving by its first point: forwards
        nodes.setdefault(_key(t[-1]), []).append((i, -1))
    trail, seg, point = _nearest(trails, start, drivable)
    t = trails[trail]
    # along the trail towards the farther of its two ends (more road before the first choice)
    ahead = np.concatenate([[point], t[seg + 1 :]])
    behind = np.concatenate([[point], t[seg::-1]])
    forwards = _length(ahead) >= _length(behind)
    pieces, used = [ahead if forwards else behind], {trail: 1}
    driven = _length(pieces[0])
    while driven < distance:
        here = pieces[-1][-1]
        heading = pieces[-1][-1] - pieces[-1][-2]
        exits = [(i, d) for i, d in nodes.get(_key(here), []) if drivable(i)]
        trail, direction = _choose(trails, exits, heading, used)
        if trail is None:
            break
        t = trails[trail] if direction > 0 else trails[trail][::-1]
        used[trail] = used.get(trail, 0) + 1
        pieces.append(t[1:] if len(pieces) else t)
        driven += _length(t)
    return _cut(np.concatenate(pieces), distance)


def _choose(trails, exits: list[tuple[int, int]], heading: np.ndarray, used: dict):
    """The trail to leave a node by: least driven, then least turn, then first listed; at a
    dead end (one trail, just driven) back the way it came."""
    best, best_rank = (None, 1), None
    for order, (i, direction) in enumerate(exits):
        t = trails[i] if direction > 0 else trails[i][::-1]
        leaving = t[1] - t[0]
        turn = abs(dm.arctan2(_cross(heading, leaving), float(np.dot(heading, leaving))))
        rank = (used.get(i, 0), round(float(turn), 9), order)
        if best_rank is None or rank < best_rank:
            best, best_rank = (i, direction), rank
    return best


def _nearest(trails: list[np.ndarray], p: np.ndarray, drivable) -> tuple[int, int, np.ndarray]:
    """(trail, segment, point): the network's drivable point nearest p."""
    found = []
    for i, t in enumerate(trails):
        a, b = t[:-1], t[1:]
        ab = b - a
        u = np.clip(((p - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0.0, 1.0)
        q = a + u[:, None] * ab
        d = ((q - p) ** 2).sum(axis=1)
        j = int(np.argmin(d))
        found.append((float(d[j]), i, j, q[j]))
    for _, i, j, q in sorted(found, key=lambda f: (f[0], f[1])):  # nearest first
        if drivable(i):
            return i, j, q
    raise UserError("has no trail the robot can drive near the start", setting="trail")


def _cut(points: np.ndarray, distance: float) -> np.ndarray:
    """The polyline's first `distance` metres (all of it when shorter); repeated points dropped."""
    steps = dm.hypot(*np.diff(points, axis=0).T)
    keep = np.concatenate([[True], steps > 1e-9])
    points, steps = points[keep], steps[steps > 1e-9]
    along = np.concatenate([[0.0], np.cumsum(steps)])
    if along[-1] <= distance:
        return points
    j = int(np.searchsorted(along, distance, side="right"))  # along[j - 1] <= distance < along[j]
    u = (distance - along[j - 1]) / steps[j - 1]
    end = points[j - 1] + u * (points[j] - points[j - 1])
    return np.concatenate([points[:j], [end]])


def _length(points: np.ndarray) -> float:
    return float(dm.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _key(p: np.ndarray) -> tuple:
    return (round(float(p[0]), NODE_DIGITS), round(float(p[1]), NODE_DIGITS))
