"""ROS bags of a drive, ROS 1 (`.bag`) and ROS 2 (rosbag2: mcap or sqlite3), written with the
`rosbags` library: no ROS installation needed (imported lazily; the `drive` extra).

Topics (docs/motion.md documents them for users):

    /laser2D          sensor_msgs/LaserScan   every 2D scan, frame `laser`
    /points           sensor_msgs/PointCloud2 every 3D scan, the raw cloud, frame `sensor`
    /points_deskewed  sensor_msgs/PointCloud2 every 3D scan, the deskewed cloud, frame `sensor`
    /tf               tf2_msgs/TFMessage      every 2D scan: odom -> base_link, base_link -> laser
    /tf_static        tf2_msgs/TFMessage      once: base_link -> sensor (latched)
    /odom             nav_msgs/Odometry       every 2D scan: base_link in odom, its velocity
    /imu              sensor_msgs/Imu         every IMU sample (with an IMU), frame `imu`

Every stamp is the simulation clock (the drive starts at 0 s). A cloud is stamped at its
3D scan's first beam and recorded in the bag when its last 2D scan ends, as a driver
publishes it; its per-point `time` is seconds after the stamp.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import UserError
from .rosbag_layout import LASER_SCAN_FIELDS, imu_layout, laser_scan_layout, odometry_layout, tf_layout

ROS2_STORAGES = ("mcap", "sqlite3")
ODOM, BASE_LINK, SENSOR, LASER, IMU = "odom", "base_link", "sensor", "laser", "imu"

# sensor_msgs/PointField datatypes
_UINT8, _UINT16, _UINT32, _FLOAT32 = 2, 4, 6, 7
# (name, offset, PointField datatype, numpy type): 32 bytes a point, every field aligned
POINT_FIELDS = (
    ("x", 0, _FLOAT32, "<f4"),
    ("y", 4, _FLOAT32, "<f4"),
    ("z", 8, _FLOAT32, "<f4"),
    ("intensity", 12, _FLOAT32, "<f4"),
    ("ring", 16, _UINT16, "<u2"),
    ("time", 20, _FLOAT32, "<f4"),
    ("label", 24, _UINT16, "<u2"),
    ("instance", 28, _UINT32, "<u4"),
)
POINT_STEP = 32
POINT_DTYPE = np.dtype(
    {
        "names": [f[0] for f in POINT_FIELDS],
        "formats": [f[3] for f in POINT_FIELDS],
        "offsets": [f[1] for f in POINT_FIELDS],
        "itemsize": POINT_STEP,
    }
)
# In weather the points carry the `weather` field too (core/effects/weather.py: 0 a surface, the
# effect's code on a particle), after the others so a clear-air cloud keeps its 32-byte layout.
WEATHER_FIELD = ("weather", 32, _UINT8, "u1")
WEATHER_POINT_STEP = 36  # 33 bytes, padded to keep every point 4-aligned
WEATHER_POINT_DTYPE = np.dtype(
    {
        "names": [f[0] for f in (*POINT_FIELDS, WEATHER_FIELD)],
        "formats": [f[3] for f in (*POINT_FIELDS, WEATHER_FIELD)],
        "offsets": [f[1] for f in (*POINT_FIELDS, WEATHER_FIELD)],
        "itemsize": WEATHER_POINT_STEP,
    }
)
# tf2_msgs is not in rosbags' ROS 1 type store: its definition as ROS 1 has it
_TF_MESSAGE_ROS1 = "geometry_msgs/TransformStamped[] transforms\n"


def require_rosbags(setting: str = "bag") -> None:
    """UserError when the rosbags library is missing (before any work is done)."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise UserError(
            "needs the rosbags library (pip install rosbags, or the `drive` extra); or give {bag} none",
            setting=setting,
            related=("bag",),
        ) from None


def point_records(xyz, intensity, ring, time, label, instance, weather=None) -> np.ndarray:
    """A cloud's PointCloud2 data as records of POINT_DTYPE, or WEATHER_POINT_DTYPE with the
    `weather` field when it is given (the padding bytes zero)."""
    out = np.zeros(len(xyz), dtype=POINT_DTYPE if weather is None else WEATHER_POINT_DTYPE)
    if weather is not None:
        out["weather"] = weather
    xyz = np.asarray(xyz, dtype=np.float32)
    out["x"], out["y"], out["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    out["intensity"], out["ring"], out["time"] = intensity, ring, time
    out["label"], out["instance"] = label, instance
    return out


class DriveBag:
    """One bag being written: `with DriveBag(path, "ros2") as bag: bag.laser_scan(...)`.
    `path` must not exist yet (a ROS 2 bag is a folder). With `imu`, it has the /imu topic."""

    def __init__(self, path: str | os.PathLike, flavour: str, storage: str = "mcap", imu: bool = False):
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        self.flavour = flavour
        self.ros1 = flavour == "ros1"
        self.has_imu = imu
        if self.ros1:
            from rosbags.rosbag1 import Writer
            from rosbags.typesys import get_types_from_msg

            self.store = get_typestore(Stores.ROS1_NOETIC)
            self.store.register(get_types_from_msg(_TF_MESSAGE_ROS1, "tf2_msgs/msg/TFMessage"))
            self.writer = Writer(self.path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            self.store = get_typestore(Stores.ROS2_JAZZY)
            plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
            self.writer = Writer(self.path, version=Writer.VERSION_LATEST, storage_plugin=plugin)
        self.types = self.store.types
        self.connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}

    # -- opening and closing ------------------------------------------------------------------

    def __enter__(self) -> "DriveBag":
        self.writer.open()
        for topic, msgtype in (
            ("/tf_static", "tf2_msgs/msg/TFMessage"),
            ("/tf", "tf2_msgs/msg/TFMessage"),
            ("/odom", "nav_msgs/msg/Odometry"),
            ("/laser2D", "sensor_msgs/msg/LaserScan"),
            ("/points", "sensor_msgs/msg/PointCloud2"),
            ("/points_deskewed", "sensor_msgs/msg/PointCloud2"),
        ):
            self._connect(topic, msgtype, latched=topic == "/tf_static")
        if self.has_imu:  # last: a drive without an IMU keeps its connection ids
            self._connect("/imu", "sensor_msgs/msg/Imu", latched=False)
        return self

    def __exit__(self, kind, value, trace) -> None:
        self.writer.close()

    def _connect(self, topic: str, msgtype: str, latched: bool) -> None:
        if self.ros1:
            extra = {"latching": 1} if latched else {}
            conn = self.writer.add_connection(
                topic, msgtype, typestore=self.store, callerid="/wildscan", **extra
            )
        else:
            extra = {"offered_qos_profiles": _latched_qos()} if latched else {}
            conn = self.writer.add_connection(topic, msgtype, typestore=self.store, **extra)
        self.connections[topic] = conn
        self.counts[topic] = 0

    def _write_bytes(self, topic: str, data, bag_ns: int) -> None:
        self.writer.write(self.connections[topic], bag_ns, data)
        self.counts[topic] += 1

    def _write(self, topic: str, message, bag_ns: int) -> None:
        msgtype = message.__msgtype__
        data = (
            self.store.serialize_ros1(message, msgtype)
            if self.ros1
            else self.store.serialize_cdr(message, msgtype)
        )
        self.writer.write(self.connections[topic], bag_ns, data)
        self.counts[topic] += 1

    # -- message parts ------------------------------------------------------------------------

    def _header(self, topic: str, stamp_ns: int, frame: str):
        time = self.types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        extra = {"seq": self.counts[topic]} if self.ros1 else {}
        return self.types["std_msgs/msg/Header"](stamp=time, frame_id=frame, **extra)

    def _vector(self, v):
        return self.types["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def _quaternion(self, q):
        return self.types["geometry_msgs/msg/Quaternion"](
            x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
        )

    def _transform(self, topic: str, stamp_ns: int, parent: str, child: str, translation, quaternion):
        transform = self.types["geometry_msgs/msg/Transform"](
            translation=self._vector(translation), rotation=self._quaternion(quaternion)
        )
        return self.types["geometry_msgs/msg/TransformStamped"](
            header=self._header(topic, stamp_ns, parent), child_frame_id=child, transform=transform
        )

    # -- messages -----------------------------------------------------------------------------

    def tf(self, stamp_ns: int, transforms, static: bool = False) -> None:
        """transforms: (parent, child, translation (3,), quaternion (x, y, z, w))."""
        topic = "/tf_static" if static else "/tf"
        stamped = [self._transform(topic, stamp_ns, *t) for t in transforms]
        self._write(topic, self.types["tf2_msgs/msg/TFMessage"](transforms=stamped), stamp_ns)

    def odometry(self, stamp_ns: int, position, quaternion, linear, angular) -> None:
        """base_link in odom (position, quaternion) and its velocity in base_link."""
        t = self.types
        zeros = np.zeros(36)
        pose = t["geometry_msgs/msg/PoseWithCovariance"](
            pose=t["geometry_msgs/msg/Pose"](
                position=t["geometry_msgs/msg/Point"](
                    x=float(position[0]), y=float(position[1]), z=float(position[2])
                ),
                orientation=self._quaternion(quaternion),
            ),
            covariance=zeros,
        )
        twist = t["geometry_msgs/msg/TwistWithCovariance"](
            twist=t["geometry_msgs/msg/Twist"](linear=self._vector(linear), angular=self._vector(angular)),
            covariance=zeros,
        )
        message = t["nav_msgs/msg/Odometry"](
            header=self._header("/odom", stamp_ns, ODOM), child_frame_id=BASE_LINK, pose=pose, twist=twist
        )
        self._write("/odom", message, stamp_ns)

    def laser_scan(self, stamp_ns: int, geometry: dict, ranges: np.ndarray, intensities: np.ndarray) -> None:
        """One 2D scan; `geometry` holds angle_min ... range_max (LaserScan's own field names)."""
        message = self.types["sensor_msgs/msg/LaserScan"](
            header=self._header("/laser2D", stamp_ns, LASER),
            ranges=np.asarray(ranges, dtype=np.float32),
            intensities=np.asarray(intensities, dtype=np.float32),
            **geometry,
        )
        self._write("/laser2D", message, stamp_ns)

    def imu(self, stamp_ns: int, orientation, gyro, accel, covariances) -> None:
        """One sensor_msgs/Imu in frame `imu`: orientation (x, y, z, w), angular velocity,
        linear acceleration; `covariances`: the three 9-element covariance matrices."""
        t = self.types
        message = t["sensor_msgs/msg/Imu"](
            header=self._header("/imu", stamp_ns, IMU),
            orientation=self._quaternion(orientation),
            orientation_covariance=np.asarray(covariances[0], dtype=np.float64),
            angular_velocity=self._vector(gyro),
            angular_velocity_covariance=np.asarray(covariances[1], dtype=np.float64),
            linear_acceleration=self._vector(accel),
            linear_acceleration_covariance=np.asarray(covariances[2], dtype=np.float64),
        )
        self._write("/imu", message, stamp_ns)

    def imu_records(self, stamps_ns: np.ndarray, orientation, gyro, accel, covariances) -> np.ndarray:
        """Many Imu messages serialized as `imu` would, (n, bytes) rows (rosbag_layout.py)."""
        stamps = np.asarray(stamps_ns, dtype=np.int64)
        values = {"sec": stamps // 10**9, "nanosec": stamps % 10**9}
        if self.ros1:  # the seq the next messages get: the caller writes them all, in order
            values["seq"] = self.counts["/imu"] + np.arange(len(stamps))
        values.update(orientation=orientation, angular_velocity=gyro, linear_acceleration=accel)
        names = ("orientation_covariance", "angular_velocity_covariance", "linear_acceleration_covariance")
        values.update(zip(names, covariances))
        return imu_layout(not self.ros1, IMU).pack(len(stamps), **values)

    def scans(
        self, stamps_ns: np.ndarray, frames, poses, odometry, geometry: dict | None, laser, imu=None
    ) -> None:
        """Many 2D scans' tf, odometry and (with `geometry`) LaserScan messages at once, each
        2D scan's in that order, serialized as `tf`, `odometry` and `laser_scan` would
        (rosbag_layout.py). `frames`: the tf's (parent, child) pairs; `poses`: their
        (translations (R, F, 3), quaternions (R, F, 4)); `odometry`: (position, quaternion,
        linear, angular), (R, 3 or 4) each; `laser`: (ranges, intensities), (R, beams) each.
        `imu`: (stamps, the arguments of `imu_records` but the stamps) of the IMU samples
        in this stretch of time, written in time order among them (a sample after the 2D
        scans' messages of its stamp)."""
        cdr = not self.ros1
        stamps = np.asarray(stamps_ns, dtype=np.int64)
        count = len(stamps)
        sec, nanosec = stamps // 10**9, stamps % 10**9
        messages = []

        def stamped(topic: str, prefixes) -> dict:
            values = {}
            for prefix in prefixes:
                values[f"{prefix}sec"], values[f"{prefix}nanosec"] = sec, nanosec
                if self.ros1:
                    values[f"{prefix}seq"] = self.counts[topic] + np.arange(count)
            return values

        translations, rotations = poses
        values = stamped("/tf", [f"{i}." for i in range(len(frames))])
        for i in range(len(frames)):
            values[f"{i}.translation"], values[f"{i}.rotation"] = translations[:, i], rotations[:, i]
        messages.append(("/tf", tf_layout(cdr, tuple(frames)).pack(count, **values)))
        position, quaternion, linear, angular = odometry
        values = stamped("/odom", [""])
        values.update(position=position, orientation=quaternion, linear=linear, angular=angular)
        messages.append(("/odom", odometry_layout(cdr, ODOM, BASE_LINK).pack(count, **values)))
        if geometry is not None:
            ranges, intensities = laser
            values = stamped("/laser2D", [""])
            values.update({name: geometry[name] for name in LASER_SCAN_FIELDS})
            values.update(ranges=ranges, intensities=intensities)
            layout = laser_scan_layout(cdr, LASER, np.shape(ranges)[1])
            messages.append(("/laser2D", layout.pack(count, **values)))
        imu_stamps, imu_raw = self._imu_rows(imu)
        before = np.searchsorted(imu_stamps, stamps, side="left").tolist() + [len(imu_stamps)]
        done = 0
        for row, stamp in enumerate(stamps.tolist()):
            done = self._write_imu(imu_stamps, imu_raw, done, before[row])
            for topic, raw in messages:
                self._write_bytes(topic, raw[row].tobytes(), stamp)
        self._write_imu(imu_stamps, imu_raw, done, before[-1])

    def _imu_rows(self, imu):
        if imu is None:
            return np.zeros(0, dtype=np.int64), None
        stamps = np.asarray(imu[0], dtype=np.int64)
        return stamps, self.imu_records(stamps, *imu[1:])

    def _write_imu(self, stamps: np.ndarray, raw, start: int, end: int) -> int:
        for i in range(start, end):
            self._write_bytes("/imu", raw[i].tobytes(), int(stamps[i]))
        return max(start, end)

    def points(self, topic: str, stamp_ns: int, bag_ns: int, records: np.ndarray) -> None:
        """One 3D scan's PointCloud2 (records of POINT_DTYPE or WEATHER_POINT_DTYPE) in frame `sensor`."""
        t = self.types
        layout = (*POINT_FIELDS, WEATHER_FIELD) if "weather" in records.dtype.names else POINT_FIELDS
        fields = [
            t["sensor_msgs/msg/PointField"](name=name, offset=offset, datatype=datatype, count=1)
            for name, offset, datatype, _ in layout
        ]
        message = t["sensor_msgs/msg/PointCloud2"](
            header=self._header(topic, stamp_ns, SENSOR),
            height=1,
            width=len(records),
            fields=fields,
            is_bigendian=False,
            point_step=records.dtype.itemsize,
            row_step=records.dtype.itemsize * len(records),
            data=np.frombuffer(records.tobytes(), dtype=np.uint8),
            is_dense=True,
        )
        self._write(topic, message, bag_ns)


def _latched_qos():
    """ROS 2's latching: a transient-local publisher (what /tf_static uses)."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    forever = QosTime(2147483647, 4294967295)
    return [
        Qos(
            QosHistory.KEEP_LAST,
            1,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL,
            forever,
            forever,
            QosLiveliness.AUTOMATIC,
            forever,
            False,
        )
    ]
