"""SPEC.toml's `like = "rellis3d" | "goose" | "wildscenes" | "semantickitti"` (`wildscan dataset
--like NAME`): the rig, mount height, label ids and files of a real dataset in one word. The
keys it sets are defaults: a key the spec gives itself wins (docs/datasets.md has the table).

Each dataset's primary lidar is the one its point labels are on:

- rellis3d: the Ouster OS1-64 (RELLIS-3D's labelled scans are `os1_cloud_node_kitti_bin`; its
  README). Height 1.14 m: unmannedlab/RELLIS-3D catkin_ws/src/platform_description/urdf/
  warthog.urdf puts the OS1's lidar frame 0.848 m above base_link (0.025 + 0.27218 + 0.445 +
  0.07 + 0.03618), and base_link 0.288 m above the ground (wheel centres 0.013 m below it,
  radius 0.3 m).
- goose: the Velodyne VLS-128 (GOOSE's labelled scans are `*_vls128.bin`; goose-dataset.de). Height
  2.0 m: an estimate for a VLS-128 on the roof of the MuCAR-3 (a VW Touareg, about 1.7 m tall);
  the GOOSE paper gives no figure found here.
- wildscenes: the VLP-16 tilted 45 deg on a 0.5 Hz turning mount (the `wildscenes` preset).
  Height 1.2 m: an estimate for a hand-carried payload (Wild-Places' and WildScenes' sensor
  payload); no figure found here.
- semantickitti: the Velodyne HDL-64E at 1.73 m (Geiger et al., "Vision meets Robotics: The KITTI
  Dataset", IJRR 2013, Fig. 3: the laser scanner 1.73 m above the ground). The `hdl64e` preset is
  the S3 (KITTI's is its S2 sibling).

Files: SemanticKITTI's .bin + .label for rellis3d, goose and semantickitti (RELLIS-3D and GOOSE
ship their scans in that format), WildScenes' own Clouds/ + Labels/ for wildscenes
(core/io/wildscenes.py).
"""

from __future__ import annotations

from dataclasses import dataclass

from ...core.errors import UserError


@dataclass(frozen=True)
class Like:
    device: str
    mount_height: float  # m
    label_scheme: str
    formats: tuple[str, ...]


LIKES: dict[str, Like] = {
    "rellis3d": Like("os1-64", 1.14, "rellis3d", ("semantickitti",)),
    "goose": Like("vls128", 2.0, "goose", ("semantickitti",)),
    "wildscenes": Like("wildscenes", 1.2, "wildscenes", ("wildscenes",)),
    "semantickitti": Like("hdl64e", 1.73, "semantickitti", ("semantickitti",)),
}


def with_like(data: dict, where: str) -> dict:
    """The spec's keys with those `like` sets filled in where the spec gives none (the spec's
    own win); `like` itself taken out. A spec without `like` comes back as it is."""
    if "like" not in data:
        return data
    name = data["like"]
    if name not in LIKES:
        allowed = ", ".join(f'"{n}"' for n in LIKES)
        raise UserError(f"{where}: like must be one of {allowed}, got {name!r}")
    like = LIKES[name]
    out = {k: v for k, v in data.items() if k != "like"}
    out.setdefault("label_scheme", like.label_scheme)
    out.setdefault("formats", list(like.formats))
    sensor = out.get("sensor", {})
    if isinstance(sensor, dict):  # (not a table: the spec's own check says so)
        sensor = dict(sensor)
        sensor.setdefault("device", like.device)
        sensor.setdefault("mount_height", like.mount_height)
        out["sensor"] = sensor
    return out
