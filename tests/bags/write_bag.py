#!/usr/bin/env python3
"""Writes the rosbag2 MCAP test bags of tests/data/ with a third-party writer (PyPI rosbags).

    scripts/ros2-jazzy-venv        # a venv with rosbags==0.11.9, linked at target/ros2-jazzy-venv
    target/ros2-jazzy-venv/bin/python tests/bags/write_bag.py jacksboro OUT.mcap
    target/ros2-jazzy-venv/bin/python tests/bags/write_bag.py mission EXPLORE_OUT_DIR OUT.mcap
    target/ros2-jazzy-venv/bin/python tests/bags/write_bag.py check BAG.mcap

`jacksboro`: the asset map assets/maps/jacksboro, revealed within 3 m of a drive through it
(what a robot's map holds), tf map -> odom -> base_link (+ base_link -> laser on /tf_static),
the landmarks (PointCloud2 in `odom`), the node's status JSON with a new goal every 10 s.
`mission`: a `fitslam explore --out DIR` run (trajectory_est.tum, map.yaml/pgm) replayed the
same way, its pose on /localization_pose (PoseWithCovarianceStamped) and no tf.
Chunks are zstd-compressed (rosbag2's storage compression). `check`: reads a bag back with
rosbags and prints its topics and message counts (used on bags `fitslam explore --bag` writes).
Standard topic names and types, as the fitslam node's defaults.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_JAZZY)
T = TS.types
ROOT = Path(__file__).resolve().parents[2]
NS = 1_000_000_000


def read_pgm(path):
    data = path.read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos : pos + 1].isspace():
            pos += 1
        if data[pos : pos + 1] == b'#':
            pos = data.index(b'\n', pos) + 1
            continue
        end = pos
        while not data[end : end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    w, h = int(fields[1]), int(fields[2])
    img = np.frombuffer(data[pos + 1 : pos + 1 + w * h], dtype=np.uint8).reshape(h, w)
    return img[::-1]  # row 0 at the bottom (map_server)


def occupancy(img):
    """Trinary map_server image -> ROS values (254 free -> 0, 0 lethal -> 100, else -1)."""
    out = np.full(img.shape, -1, dtype=np.int8)
    out[img >= 250] = 0
    out[img <= 50] = 100
    return out


def stamp(t_ns):
    return T['builtin_interfaces/msg/Time'](sec=t_ns // NS, nanosec=t_ns % NS)


def header(t_ns, frame):
    return T['std_msgs/msg/Header'](stamp=stamp(t_ns), frame_id=frame)


def quat(yaw):
    return T['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def transform(t_ns, parent, child, x, y, yaw):
    tr = T['geometry_msgs/msg/Transform'](translation=T['geometry_msgs/msg/Vector3'](x=x, y=y, z=0.0), rotation=quat(yaw))
    return T['geometry_msgs/msg/TransformStamped'](header=header(t_ns, parent), child_frame_id=child, transform=tr)


def grid_msg(t_ns, values, res, origin):
    pose = T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=origin[0], y=origin[1], z=0.0), orientation=quat(0.0))
    h, w = values.shape
    info = T['nav_msgs/msg/MapMetaData'](map_load_time=stamp(t_ns), resolution=res, width=w, height=h, origin=pose)
    return T['nav_msgs/msg/OccupancyGrid'](header=header(t_ns, 'map'), info=info, data=values.reshape(-1).astype(np.int8))


def cloud_msg(t_ns, frame, pts):
    F = T['sensor_msgs/msg/PointField']
    fields = [F(name=n, offset=4 * i, datatype=F.FLOAT32, count=1) for i, n in enumerate('xyz')]
    data = np.asarray(pts, dtype='<f4').reshape(-1).view(np.uint8)
    return T['sensor_msgs/msg/PointCloud2'](
        header=header(t_ns, frame), height=1, width=len(pts), fields=fields, is_bigendian=False,
        point_step=12, row_step=12 * len(pts), data=data, is_dense=True)


def status_msg(t_s, goal_id, goal, robot):
    g = None if goal is None else {
        'id': goal_id, 'goal': {'x_m': goal[0], 'y_m': goal[1], 'yaw_rad': 0.0}, 'frontier_m': [goal[0], goal[1]],
        'sent_s': t_s, 'accepted_s': t_s, 'inflation_m': 0.3, 'on_trail': False}
    st = {'t_s': t_s, 'phase': 'navigating' if g else 'planning', 'goal': g,
          'robot': {'x_m': robot[0], 'y_m': robot[1], 'yaw_rad': robot[2]}, 'candidates': 0, 'ranked': 0}
    return T['std_msgs/msg/String'](data=json.dumps(st))


def revealed(full, res, origin, seen_xy, radius_m):
    """The cells of `full` within `radius_m` of any position driven so far; unknown elsewhere."""
    h, w = full.shape
    ys, xs = np.mgrid[0:h, 0:w]
    cx, cy = origin[0] + (xs + 0.5) * res, origin[1] + (ys + 0.5) * res
    mask = np.zeros(full.shape, dtype=bool)
    for x, y in seen_xy:
        mask |= (cx - x) ** 2 + (cy - y) ** 2 <= radius_m ** 2
    return np.where(mask, full, np.int8(-1)).astype(np.int8)


class Bag:
    def __init__(self, out):
        self.w = Writer(Path(out), version=9, storage_plugin=StoragePlugin.MCAP)
        self.w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self.conns = {}

    def __enter__(self):
        self.w.open()
        return self

    def __exit__(self, *exc):
        self.w.close()

    def put(self, topic, msgtype, t_ns, msg):
        if topic not in self.conns:
            self.conns[topic] = self.w.add_connection(topic, msgtype, typestore=TS)
        self.w.write(self.conns[topic], t_ns, TS.serialize_cdr(msg, msgtype))


def write(out, full, res, origin, poses, landmarks, use_tf, goal_every_s=10.0, map_every_s=5.0):
    """`poses`: [(t_s, x, y, yaw)] in the map frame; odom is offset from map by (0.2, -0.1)."""
    tmp = Path(out).with_suffix('.dir')
    with Bag(tmp) as b:
        b.put('/tf_static', 'tf2_msgs/msg/TFMessage', 0, T['tf2_msgs/msg/TFMessage'](transforms=[transform(0, 'base_link', 'laser', 0.1, 0.0, 0.0)]))
        seen, next_map, next_goal, goal_id = [], 0.0, 0.0, 0
        odom = (0.2, -0.1)
        for k, (t_s, x, y, yaw) in enumerate(poses):
            t_ns = int(round(t_s * NS))
            seen.append((x, y))
            if use_tf:
                tfs = [transform(t_ns, 'map', 'odom', odom[0], odom[1], 0.0), transform(t_ns, 'odom', 'base_link', x - odom[0], y - odom[1], yaw)]
                b.put('/tf', 'tf2_msgs/msg/TFMessage', t_ns, T['tf2_msgs/msg/TFMessage'](transforms=tfs))
            else:
                pose = T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x=x, y=y, z=0.0), orientation=quat(yaw))
                cov = np.zeros(36)
                cov[0] = cov[7] = 0.01
                pwc = T['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=cov)
                b.put('/localization_pose', 'geometry_msgs/msg/PoseWithCovarianceStamped', t_ns,
                      T['geometry_msgs/msg/PoseWithCovarianceStamped'](header=header(t_ns, 'map'), pose=pwc))
            if t_s >= next_map:
                next_map += map_every_s
                b.put('/map', 'nav_msgs/msg/OccupancyGrid', t_ns + 1000, grid_msg(t_ns, revealed(full, res, origin, seen, 3.0), res, origin))
                if landmarks is not None:
                    near = [p for p in landmarks if any((p[0] - sx) ** 2 + (p[1] - sy) ** 2 < 9.0 for sx, sy in seen[-50:])]
                    in_odom = [(p[0] - odom[0], p[1] - odom[1], p[2]) for p in near]
                    b.put('/cloud_map', 'sensor_msgs/msg/PointCloud2', t_ns + 2000, cloud_msg(t_ns, 'odom', in_odom))
            if t_s >= next_goal:
                next_goal += goal_every_s
                goal_id += 1
                ahead = poses[min(k + 40, len(poses) - 1)]
                b.put('/fitslam/status', 'std_msgs/msg/String', t_ns + 3000, status_msg(t_s, goal_id, (ahead[1], ahead[2]), (x, y, yaw)))
    mcap = next(tmp.glob('*.mcap'))
    Path(out).write_bytes(mcap.read_bytes())
    for f in tmp.iterdir():
        f.unlink()
    tmp.rmdir()


def jacksboro(out):
    d = ROOT / 'assets/maps/jacksboro'
    full = occupancy(read_pgm(d / 'map.pgm'))
    res, origin = 0.05, (0.0, 0.0)
    # A drive through the scene's viewpoints at 0.3 m/s, one pose every 0.5 s.
    way = [(3.0, 3.0), (6.5, 4.0), (4.5, 7.5)]
    poses, t = [], 0.0
    for (x0, y0), (x1, y1) in zip(way, way[1:]):
        n = int(math.hypot(x1 - x0, y1 - y0) / 0.15)
        yaw = math.atan2(y1 - y0, x1 - x0)
        for i in range(n):
            poses.append((t, x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * i / n, yaw))
            t += 0.5
    rows = np.genfromtxt(d / 'landmarks.csv', delimiter=',', names=True)
    landmarks = [(float(r['x']), float(r['y']), float(r['z'])) for r in rows[::4]]
    write(out, full, res, origin, poses, landmarks, use_tf=True)


def mission(run_dir, out):
    run = Path(run_dir)
    yaml = dict(line.split(':', 1) for line in (run / 'map.yaml').read_text().splitlines() if ':' in line)
    res = float(yaml['resolution'])
    origin = [float(v) for v in yaml['origin'].strip().strip('[]').split(',')][:2]
    full = occupancy(read_pgm(run / yaml['image'].strip()))
    poses = []
    for line in (run / 'trajectory_est.tum').read_text().splitlines():
        t, x, y, _z, qx, qy, qz, qw = map(float, line.split())
        poses.append((t, x, y, math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))))
    poses = poses[::max(1, len(poses) // 300)]
    write(out, full, res, origin, poses, None, use_tf=False)


def check(path):
    with AnyReader([Path(path)], default_typestore=TS) as r:
        counts = {}
        for conn, _t, raw in r.messages():
            r.deserialize(raw, conn.msgtype)
            counts[(conn.topic, conn.msgtype)] = counts.get((conn.topic, conn.msgtype), 0) + 1
        for (topic, msgtype), n in sorted(counts.items()):
            print(f'{topic} {msgtype} {n}')


if __name__ == '__main__':
    cmd = sys.argv[1]
    {'jacksboro': jacksboro, 'mission': mission, 'check': check}[cmd](*sys.argv[2:])
