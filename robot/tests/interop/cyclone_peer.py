#!/usr/bin/env python3
"""An independent DDS peer for fitslam-robot: Eclipse Cyclone DDS (PyPI `cyclonedds`, the DDS under
ROS 2's rmw_cyclonedds), with the ROS 2 message types declared here from the .msg files.

It publishes what a robot publishes -- a nav_msgs/OccupancyGrid map (transient local), a
sensor_msgs/PointCloud2 landmark cloud and tf2_msgs/TFMessage poses -- and waits for the node's
geometry_msgs/PoseStamped goal on /goal_pose and its std_msgs/String status. The world is a
corridor open at both ends with landmarks only east of the robot, so FIT-SLAM must pick the east
frontier. Exit status 0 and a line "INTEROP OK ..." when the goal is in the map frame, east of
the robot and on a free cell of the inflated map; 1 otherwise (with the reason).

Usage: cyclone_peer.py DOMAIN_ID TIMEOUT_S   (loopback-only is set through CYCLONEDDS_URI)
"""

import json
import math
import struct
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float32, float64, int8, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


# --- ROS 2 message types, field order as in the .msg files ---------------------------------------
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
class MapMetaData(IdlStruct, typename="nav_msgs::msg::dds_::MapMetaData_"):
    map_load_time: Time
    resolution: float32
    width: uint32
    height: uint32
    origin: Pose


@dataclass
class OccupancyGrid(IdlStruct, typename="nav_msgs::msg::dds_::OccupancyGrid_"):
    header: Header
    info: MapMetaData
    data: sequence[int8]


@dataclass
class PointField(IdlStruct, typename="sensor_msgs::msg::dds_::PointField_"):
    name: str
    offset: uint32
    datatype: uint8
    count: uint32


@dataclass
class PointCloud2(IdlStruct, typename="sensor_msgs::msg::dds_::PointCloud2_"):
    header: Header
    height: uint32
    width: uint32
    fields: sequence[PointField]
    is_bigendian: bool
    point_step: uint32
    row_step: uint32
    data: sequence[uint8]
    is_dense: bool


# --- the world ----------------------------------------------------------------------------------
W, H, RES = 240, 40, 0.1
FREE, LETHAL, UNKNOWN = 0, 100, -1
ROBOT = (11.55, 2.05)
ROBOT_RADIUS_M = 0.25


def corridor():
    """A 2 m wide corridor from x = 4.0 to 19.6 m (free rows 10..29, walls on rows 9 and 30)."""
    grid = [UNKNOWN] * (W * H)
    for c in range(40, 196):
        for r in range(9, 31):
            grid[r * W + c] = LETHAL if r in (9, 30) else FREE
    return grid


def inflated_free(grid, x, y):
    """Whether (x, y) is free on the grid inflated by the robot radius."""
    c, r = int(math.floor(x / RES)), int(math.floor(y / RES))
    if not (0 <= c < W and 0 <= r < H) or grid[r * W + c] != FREE:
        return False
    k = int(ROBOT_RADIUS_M / RES)
    for dr in range(-k, k + 1):
        for dc in range(-k, k + 1):
            if dc * dc + dr * dr <= (ROBOT_RADIUS_M / RES) ** 2 + 1e-9:
                cc, rr = c + dc, r + dr
                if 0 <= cc < W and 0 <= rr < H and grid[rr * W + cc] == LETHAL:
                    return False
    return True


def stamp():
    t = time.time()
    return Time(sec=int(t), nanosec=int((t - int(t)) * 1e9))


def main():
    domain, timeout_s = int(sys.argv[1]), float(sys.argv[2])
    dp = DomainParticipant(domain)
    reliable = Policy.Reliability.Reliable(duration(seconds=1))
    latched = Qos(reliable, Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
    volatile = Qos(reliable, Policy.Durability.Volatile, Policy.History.KeepLast(10))

    map_w = DataWriter(dp, Topic(dp, "rt/map", OccupancyGrid), qos=latched)
    cloud_w = DataWriter(dp, Topic(dp, "rt/cloud_map", PointCloud2), qos=volatile)
    tf_w = DataWriter(dp, Topic(dp, "rt/tf", TFMessage), qos=volatile)
    goal_r = DataReader(dp, Topic(dp, "rt/goal_pose", PoseStamped), qos=volatile)
    status_r = DataReader(dp, Topic(dp, "rt/fitslam/status", String), qos=volatile)

    grid = corridor()
    identity = Quaternion(0.0, 0.0, 0.0, 1.0)
    landmarks = []
    x = 11.6
    while x < 19.6:
        landmarks += [(x, 0.95, 0.5), (x, 3.05, 0.5)]
        x += 0.2
    # Big-endian float64 on purpose: the node must honour is_bigendian, point_step and offsets.
    cloud_data = b"".join(struct.pack(">4xddd", *p) for p in landmarks)
    fields = [PointField(n, 4 + 8 * i, 8, 1) for i, n in enumerate("xyz")]

    t0, last_pub, statuses = time.time(), 0.0, 0
    while time.time() - t0 < timeout_s:
        now = time.time()
        if now - last_pub >= 0.5:
            last_pub = now
            map_w.write(OccupancyGrid(
                header=Header(stamp(), "map"),
                info=MapMetaData(stamp(), RES, W, H, Pose(Point(0.0, 0.0, 0.0), identity)),
                data=grid))
            cloud_w.write(PointCloud2(
                header=Header(stamp(), "map"), height=1, width=len(landmarks), fields=fields,
                is_bigendian=True, point_step=28, row_step=28 * len(landmarks),
                data=list(cloud_data), is_dense=True))
        tf_w.write(TFMessage(transforms=[
            TransformStamped(Header(stamp(), "map"), "odom", Transform(Vector3(0.0, 0.0, 0.0), identity)),
            TransformStamped(Header(stamp(), "odom"), "base_link",
                             Transform(Vector3(ROBOT[0], ROBOT[1], 0.0), identity)),
        ]))
        for s in status_r.take(N=20):
            statuses += 1
            json.loads(s.data)  # the status must be valid JSON
        for g in goal_r.take(N=10):
            gx, gy = g.pose.position.x, g.pose.position.y
            q = g.pose.orientation
            norm = math.sqrt(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2)
            problems = []
            if g.header.frame_id != "map":
                problems.append(f"frame '{g.header.frame_id}'")
            if not inflated_free(grid, gx, gy):
                problems.append("goal not on a free cell of the inflated map")
            if not gx > ROBOT[0] + 5.0:
                problems.append("goal is not at the east frontier (where the landmarks are)")
            if abs(norm - 1.0) > 1e-6:
                problems.append(f"quaternion norm {norm}")
            if problems:
                print(f"INTEROP FAIL goal=({gx:.2f}, {gy:.2f}): " + "; ".join(problems), flush=True)
                return 1
            print(f"INTEROP OK goal=({gx:.2f}, {gy:.2f}) yaw_z={q.z:.3f} statuses={statuses}", flush=True)
            return 0
        time.sleep(0.05)
    print(f"INTEROP FAIL: no goal within {timeout_s} s (statuses received: {statuses})", flush=True)
    return 1


if __name__ == "__main__":
    sys.exit(main())
