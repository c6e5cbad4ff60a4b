"""Class weights for training on a dataset (numpy only): per class of the label scheme's
learning map (the ids a network predicts), from the point counts of the dataset written.

    inverse frequency   w_c = N / (K · n_c)          (mean 1 over the K classes with points:
                                                      scikit-learn's class_weight="balanced")
    ENet                w_c = 1 / ln(1.02 + p_c)     (p_c = n_c / N; Paszke et al., "ENet: A Deep
                                                      Neural Network Architecture for Real-Time
                                                      Semantic Segmentation", arXiv:1606.02147,
                                                      2016, Sec. 5.2: bounded, 1/ln(1.02) ≈ 50.5 at most)

N counts the points of classes the learning map does not ignore. An ignored class, and a
class with no point in the dataset, weighs 0 (a loss over it has nothing to learn from).
"""

from __future__ import annotations

import json
import math

from .label_schemes import LabelScheme

ENET_C = 1.02  # ENet's constant (Paszke et al. 2016, Sec. 5.2)


def learning_counts(scheme: LabelScheme, raw_counts: dict[int, int], classes) -> dict[int, int]:
    """Points per learning-map class (every class the map has, 0 where none) from points per
    raw label id of the scheme; `classes`: those the data lists (classes.listed_classes)."""
    tables = scheme.config_tables(classes)
    learning_map, ignore = tables["learning_map"], tables["learning_ignore"]
    out = {xid: 0 for xid in sorted(set(learning_map.values()))}
    for raw, n in raw_counts.items():
        xid = learning_map.get(raw)
        if xid is not None and not ignore.get(xid, False):
            out[xid] += int(n)
    return out


def class_weights(counts: dict[int, int]) -> dict[str, dict[int, float]]:
    """{"inverse_frequency": {id: w}, "enet": {id: w}} for the learning classes in `counts`."""
    total = sum(counts.values())
    present = [xid for xid, n in counts.items() if n > 0]
    inverse, enet = {}, {}
    for xid, n in counts.items():
        if n <= 0 or total <= 0:
            inverse[xid] = enet[xid] = 0.0
            continue
        inverse[xid] = total / (len(present) * n)
        enet[xid] = 1.0 / math.log(ENET_C + n / total)
    return {"inverse_frequency": inverse, "enet": enet}


def weights_json(scheme: LabelScheme, counts: dict[int, int], classes) -> str:
    """weights.json: per learning class its name, points, share and both weights."""
    tables = scheme.config_tables(classes)
    weights = class_weights(counts)
    total = max(1, sum(counts.values()))
    names = {xid: scheme.labels.get(raw, str(raw)) for xid, raw in tables["learning_map_inv"].items()}
    classes = {
        str(xid): {
            "name": names.get(xid, str(xid)),
            "points": n,
            "share": n / total,
            "ignored": bool(tables["learning_ignore"].get(xid, False)),
            "inverse_frequency": weights["inverse_frequency"][xid],
            "enet": weights["enet"][xid],
        }
        for xid, n in counts.items()
    }
    data = {
        "label_scheme": scheme.name,
        "ids": "the learning map's (labels.yaml learning_map): what a network predicts",
        "inverse_frequency": "N / (K n_c) over the K classes with points (mean 1)",
        "enet": "1 / ln(1.02 + n_c / N) (Paszke et al. 2016, arXiv:1606.02147, Sec. 5.2)",
        "classes": classes,
    }
    return json.dumps(data, indent=1, sort_keys=True) + "\n"
