"""The robot's ROS 2 stack for fitslam-robot's rclpy tests, on ROS 2 Jazzy's official Python
client (rclpy on rmw_fastrtps_cpp, Fast DDS):

- a simulated robot in a ground-truth grid world (from --world, written by the Rust test): a
  perfect 2D range sensor reveals the map around it, it drives along A* paths on the inflated
  ground truth;
- the SLAM / map side: nav_msgs/OccupancyGrid on /map (TRANSIENT_LOCAL, RELIABLE, depth 1, as
  map_server and the SLAMs publish it; cropped to the known cells plus 1 m, so that it grows),
  tf2_msgs/TFMessage on /tf (map -> odom -> base_link) and /tf_static (base_link -> camera_link),
  the landmark map as sensor_msgs/PointCloud2 on /cloud_map, the pose with its covariance as
  geometry_msgs/PoseWithCovarianceStamped on /localization_pose;
- Nav2's stand-in: an rclpy ActionServer for nav2_msgs/action/NavigateToPose on
  /navigate_to_pose that drives the robot to the goal with feedback, and succeeds, aborts,
  rejects or is cancelled;
- a monitor: the node's JSON status on /fitslam/status and its MarkerArray on /fitslam/markers.

--faults all injects, in one run: a volatile /map publisher before the real one (a QoS the node
cannot match), a pose that comes late (no tf for 3 s after the map, then 2 s without the SLAM's
map -> odom link), the action server destroyed and created again during a goal, an aborted
goal (the 3rd), a rejected goal (the 4th), tf going stale for 4 s, map -> odom stopping for 4 s,
a map whose data does not match its width x height (once), and a map whose size changes (it
grows, every second). --faults none runs the clean loop.

Writes a JSON summary to --out when the node reports `done` or at --limit seconds.
"""

import argparse
import heapq
import json
import math
import struct
import threading
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import OccupancyGrid
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
VOLATILE_MAP = QoSProfile(depth=1, durability=DurabilityPolicy.VOLATILE, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
TF_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.VOLATILE, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
TF_STATIC_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)

# map -> odom: what a SLAM's drift correction looks like (x, y, yaw).
MAP_TO_ODOM = (0.4, -0.3, 0.1)


def compose(a, b):
    """a * b for planar poses (x, y, yaw)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


class World:
    """Ground truth, the known map and the robot; every method is called under `lock`."""

    def __init__(self, spec):
        self.res = spec["resolution_m"]
        self.ox, self.oy = spec["origin_m"]
        self.w, self.h = spec["width"], spec["height"]
        self.truth = np.array(spec["data"], dtype=np.int8).reshape(self.h, self.w)
        self.radius = spec["robot_radius_m"]
        self.range_m = spec["range_m"]
        self.speed = spec["speed_mps"]
        self.pose = list(spec["start"])
        self.known = np.full((self.h, self.w), -1, dtype=np.int8)
        self.path = []
        self.goal_yaw = 0.0
        self.driving_for = None  # the goal the path serves
        self.lock = threading.Lock()
        lethal = self.truth >= 50
        r = int(math.ceil(self.radius / self.res))
        inflated = lethal.copy()
        for dr in range(-r, r + 1):
            for dc in range(-r, r + 1):
                if dr * dr + dc * dc <= r * r:
                    inflated |= np.roll(np.roll(lethal, dr, axis=0), dc, axis=1)
        self.blocked = inflated
        # Landmarks on every third obstacle cell next to free ground, 0.5 m up.
        free = self.truth == 0
        edge = lethal & (np.roll(free, 1, 0) | np.roll(free, -1, 0) | np.roll(free, 1, 1) | np.roll(free, -1, 1))
        cells = list(zip(*np.nonzero(edge)))[2::3]
        self.landmarks = [(r_, c_, self.ox + (c_ + 0.5) * self.res, self.oy + (r_ + 0.5) * self.res) for r_, c_ in cells]
        # Reachable free cells (4-neighbours from the start), the exploration's denominator.
        self.reachable = np.zeros_like(free)
        start = self.cell(self.pose[0], self.pose[1])
        stack = [start]
        self.reachable[start] = True
        while stack:
            rr, cc = stack.pop()
            for nr, nc in ((rr + 1, cc), (rr - 1, cc), (rr, cc + 1), (rr, cc - 1)):
                if 0 <= nr < self.h and 0 <= nc < self.w and free[nr, nc] and not self.reachable[nr, nc]:
                    self.reachable[nr, nc] = True
                    stack.append((nr, nc))
        angles = np.radians(np.arange(360.0))
        steps = np.arange(0.0, self.range_m, 0.5 * self.res)
        self.ray_dx = np.outer(np.cos(angles), steps)
        self.ray_dy = np.outer(np.sin(angles), steps)
        self.scan()

    def cell(self, x, y):
        return (int(math.floor((y - self.oy) / self.res)), int(math.floor((x - self.ox) / self.res)))

    def inside(self, rc):
        return 0 <= rc[0] < self.h and 0 <= rc[1] < self.w

    def truth_free(self, x, y):
        rc = self.cell(x, y)
        return self.inside(rc) and self.truth[rc] == 0

    def scan(self):
        """Reveals the cells in line of sight within range (one ray per degree)."""
        cols = np.floor((self.pose[0] + self.ray_dx - self.ox) / self.res).astype(int)
        rows = np.floor((self.pose[1] + self.ray_dy - self.oy) / self.res).astype(int)
        outside = (cols < 0) | (cols >= self.w) | (rows < 0) | (rows >= self.h)
        cols, rows = np.clip(cols, 0, self.w - 1), np.clip(rows, 0, self.h - 1)
        stop = outside | (self.truth[rows, cols] >= 50)
        # Samples up to and including the first obstacle, none past the map's edge.
        first = np.where(stop.any(axis=1), stop.argmax(axis=1), stop.shape[1])
        keep = np.arange(stop.shape[1])[None, :] <= first[:, None]
        keep &= ~outside
        self.known[rows[keep], cols[keep]] = self.truth[rows[keep], cols[keep]]

    def plan(self, gx, gy):
        """A* over the inflated ground truth (8-neighbours) to the goal; None if there is none."""
        start, goal = self.cell(self.pose[0], self.pose[1]), self.cell(gx, gy)
        if not self.inside(goal) or self.blocked[goal]:
            return None
        dist = {start: 0.0}
        came = {}
        todo = [(0.0, start)]
        while todo:
            _, cur = heapq.heappop(todo)
            if cur == goal:
                cells = []
                while cur in came:
                    cells.append(cur)
                    cur = came[cur]
                pts = [(self.ox + (c + 0.5) * self.res, self.oy + (r + 0.5) * self.res) for r, c in reversed(cells)]
                return pts + [(gx, gy)]
            for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
                nxt = (cur[0] + dr, cur[1] + dc)
                if not self.inside(nxt) or self.blocked[nxt]:
                    continue
                d = dist[cur] + math.hypot(dr, dc)
                if d < dist.get(nxt, math.inf):
                    dist[nxt] = d
                    came[nxt] = cur
                    heapq.heappush(todo, (d + math.hypot(goal[0] - nxt[0], goal[1] - nxt[1]), nxt))
        return None

    def advance(self, dt):
        """Drives along the path; True when the goal has just been reached."""
        if not self.path:
            return False
        budget = self.speed * dt
        while budget > 0 and self.path:
            tx, ty = self.path[0]
            dx, dy = tx - self.pose[0], ty - self.pose[1]
            d = math.hypot(dx, dy)
            if d <= budget:
                self.pose[0], self.pose[1] = tx, ty
                budget -= d
                self.path.pop(0)
            else:
                self.pose[0] += dx / d * budget
                self.pose[1] += dy / d * budget
                self.pose[2] = math.atan2(dy, dx)
                budget = 0
        self.scan()
        if not self.path:
            self.pose[2] = self.goal_yaw
            return True
        return False

    def remaining_m(self):
        pts = [tuple(self.pose[:2])] + self.path
        return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))

    def cropped(self):
        """The known map's bounding box plus 1 m: (origin x, origin y, width, height, data)."""
        rows, cols = np.nonzero(self.known != -1)
        m = int(round(1.0 / self.res))
        r0, r1 = max(rows.min() - m, 0), min(rows.max() + m, self.h - 1)
        c0, c1 = max(cols.min() - m, 0), min(cols.max() + m, self.w - 1)
        sub = self.known[r0 : r1 + 1, c0 : c1 + 1]
        return self.ox + c0 * self.res, self.oy + r0 * self.res, c1 + 1 - c0, r1 + 1 - r0, sub

    def explored(self):
        n = int(self.reachable.sum())
        return float(((self.known == 0) & self.reachable).sum()) / max(n, 1)


def yaw_quaternion(q, yaw):
    q.z, q.w = math.sin(yaw / 2), math.cos(yaw / 2)


def transform(stamp, parent, child, xyz_yaw, z=0.0):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz_yaw[0], xyz_yaw[1], z
    yaw_quaternion(t.transform.rotation, xyz_yaw[2])
    return t


class Stack:
    def __init__(self, args, spec):
        self.world = World(spec)
        self.faults = args.faults
        self.t0 = time.monotonic()
        self.events = []  # (t, what) the stack did, for the summary
        self.slam = Node("slam_stand_in")
        self.nav = Node("nav2_stand_in")
        self.monitor = Node("fitslam_monitor")
        sim_group = MutuallyExclusiveCallbackGroup()
        self.map_pub = self.slam.create_publisher(OccupancyGrid, "/map", LATCHED)
        self.volatile_map_pub = self.slam.create_publisher(OccupancyGrid, "/map", VOLATILE_MAP) if self.faults == "all" else None
        self.tf_pub = self.slam.create_publisher(TFMessage, "/tf", TF_QOS)
        self.tf_static_pub = self.slam.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
        self.pose_pub = self.slam.create_publisher(PoseWithCovarianceStamped, "/localization_pose", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self.landmark_pub = self.slam.create_publisher(PointCloud2, "/cloud_map", QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))
        self.slam.create_timer(0.05, self.step, callback_group=sim_group)
        self.slam.create_timer(1.0, self.publish_map, callback_group=sim_group)
        self.statuses = []
        self.markers = {}
        self.marker_goals = []
        self.monitor.create_subscription(String, "/fitslam/status", self.on_status, LATCHED)
        self.monitor.create_subscription(MarkerArray, "/fitslam/markers", self.on_markers, QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE))
        self.goals = []  # every goal the server received: [x, y, outcome]
        self.generation = 0  # bumped when the action server is restarted
        self.server_group = ReentrantCallbackGroup()
        self.server = self.make_server()
        self.restarted = False
        self.bad_map_sent = False
        self.tf_off_until = 0.0
        self.map_odom_off_until = 0.0
        self.map_started = False
        self.first_map_t = None
        self.publish_static()

    def now(self):
        return time.monotonic() - self.t0

    def log(self, what):
        self.events.append((round(self.now(), 2), what))
        print(f"[stack {self.now():6.2f}] {what}", flush=True)

    def make_server(self):
        return ActionServer(
            self.nav,
            NavigateToPose,
            "/navigate_to_pose",
            execute_callback=self.execute,
            goal_callback=self.on_goal,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=self.server_group,
        )

    def publish_static(self):
        stamp = self.slam.get_clock().now().to_msg()
        self.tf_static_pub.publish(TFMessage(transforms=[transform(stamp, "base_link", "camera_link", (0.1, 0.0, 0.0), z=0.2)]))

    # ---------------------------------------------------------------- the map and the pose
    def map_msg(self):
        with self.world.lock:
            ox, oy, w, h, sub = self.world.cropped()
        m = OccupancyGrid()
        m.header.stamp = self.slam.get_clock().now().to_msg()
        m.header.frame_id = "map"
        m.info.resolution = float(self.world.res)
        m.info.width, m.info.height = int(w), int(h)
        m.info.origin.position.x, m.info.origin.position.y = float(ox), float(oy)
        m.info.origin.orientation.w = 1.0
        m.data = sub.astype(np.int8).ravel().tolist()
        return m

    def publish_map(self):
        t = self.now()
        if self.volatile_map_pub is not None and t >= 6.0:
            self.slam.destroy_publisher(self.volatile_map_pub)
            self.volatile_map_pub = None
        if self.volatile_map_pub is not None:
            # A QoS the node cannot match: the node subscribes TRANSIENT_LOCAL, as map_server publishes.
            if not self.map_started:
                self.log("publishing /map VOLATILE only (QoS mismatch)")
                self.map_started = True
            self.volatile_map_pub.publish(self.map_msg())
            return
        if self.first_map_t is None:
            self.first_map_t = t
            self.log("publishing /map TRANSIENT_LOCAL")
        m = self.map_msg()
        if self.faults == "all" and not self.bad_map_sent and t > self.first_map_t + 8.0:
            # A map whose data does not match its size (a broken SLAM or bridge): one message.
            self.bad_map_sent = True
            m.info.width += 7
            self.log("publishing a map whose data does not match its width x height")
        self.map_pub.publish(m)
        self.publish_landmarks()

    def publish_landmarks(self):
        with self.world.lock:
            seen = [(x, y) for r, c, x, y in self.world.landmarks if self.world.known[r, c] != -1]
        cloud = PointCloud2()
        cloud.header.stamp = self.slam.get_clock().now().to_msg()
        cloud.header.frame_id = "map"
        cloud.height, cloud.width = 1, len(seen)
        cloud.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
        cloud.is_bigendian = False
        cloud.point_step = 12
        cloud.row_step = 12 * len(seen)
        cloud.data = b"".join(struct.pack("<fff", x, y, 0.5) for x, y in seen)
        cloud.is_dense = True
        self.landmark_pub.publish(cloud)

    def step(self):
        with self.world.lock:
            self.world.advance(0.05)
            pose = tuple(self.world.pose)
        t = self.now()
        if self.first_map_t is None:
            return
        late = self.faults == "all" and t < self.first_map_t + 3.0
        if late or t < self.tf_off_until:
            return  # the pose comes late (3 s after the map), or tf is stale
        # For 2 s after that, the SLAM's map -> odom link is missing.
        link_missing = self.faults == "all" and t < self.first_map_t + 5.0
        stamp = self.slam.get_clock().now().to_msg()
        odom_to_base = compose(inverse(MAP_TO_ODOM), pose)
        tfs = [transform(stamp, "odom", "base_link", odom_to_base)]
        if t >= self.map_odom_off_until and not link_missing:
            tfs.append(transform(stamp, "map", "odom", MAP_TO_ODOM))
        self.tf_pub.publish(TFMessage(transforms=tfs))
        # The SLAM's pose with its covariance, in map (RTAB-Map's /localization_pose).
        msg = PoseWithCovarianceStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = "map"
        msg.pose.pose.position.x, msg.pose.pose.position.y = pose[0], pose[1]
        yaw_quaternion(msg.pose.pose.orientation, pose[2])
        msg.pose.covariance[0] = msg.pose.covariance[7] = 0.01
        msg.pose.covariance[35] = 0.001
        self.pose_pub.publish(msg)

    # ---------------------------------------------------------------- Nav2's stand-in
    def on_goal(self, request):
        p = request.pose.pose.position
        self.goals.append([p.x, p.y, "received"])
        k = len(self.goals)
        if self.faults == "all" and k == 4:
            self.goals[-1][2] = "rejected"
            self.log(f"goal {k} at ({p.x:.2f}, {p.y:.2f}): rejected")
            return GoalResponse.REJECT
        self.log(f"goal {k} at ({p.x:.2f}, {p.y:.2f}): accepted (frame {request.pose.header.frame_id})")
        return GoalResponse.ACCEPT

    def execute(self, gh):
        k = len(self.goals)
        generation = self.generation
        goal = gh.request.pose.pose
        gx, gy = goal.position.x, goal.position.y
        yaw = 2 * math.atan2(goal.orientation.z, goal.orientation.w)
        result = NavigateToPose.Result()
        started = self.now()
        if self.faults == "all" and k == 3:
            time.sleep(0.5)
            return self.abort(gh, k, "aborted", "aborted by the test's Nav2 stand-in")
        with self.world.lock:
            path = self.world.plan(gx, gy)
            if path is not None:
                self.world.path = path
                self.world.goal_yaw = yaw
                self.world.driving_for = k
        if path is None:
            return self.abort(gh, k, "aborted: no path", "no path")
        while True:
            time.sleep(0.05)
            t = self.now()
            if generation != self.generation:
                self.goals[k - 1][2] = "lost in a server restart"
                return result
            if gh.is_cancel_requested:
                with self.world.lock:
                    if self.world.driving_for == k:
                        self.world.path = []
                self.goals[k - 1][2] = "cancelled"
                self.log(f"goal {k}: cancelled by the client")
                gh.canceled()
                return result
            with self.world.lock:
                if self.world.driving_for != k:
                    # A newer goal took over the robot (the client sent it before cancelling this one).
                    return self.abort(gh, k, "superseded", "superseded by a newer goal")
                arrived = not self.world.path
                remaining = self.world.remaining_m()
                pose = tuple(self.world.pose)
            if arrived:
                self.goals[k - 1][2] = "succeeded"
                self.log(f"goal {k}: succeeded")
                gh.succeed()
                return result
            if self.faults == "all" and k >= 2 and not self.restarted and t - started > 0.5:
                self.restarted = True
                threading.Thread(target=self.restart_server, daemon=True).start()
                self.generation += 1
                continue
            if self.faults == "all" and k >= 5 and self.restarted and self.tf_off_until == 0.0:
                self.tf_off_until = t + 4.0
                self.log("tf stale for 4 s")
            if self.faults == "all" and k >= 7 and 0.0 < self.tf_off_until < t - 2.0 and self.map_odom_off_until == 0.0:
                self.map_odom_off_until = t + 4.0
                self.log("tf without map -> odom for 4 s")
            fb = NavigateToPose.Feedback()
            fb.current_pose.header.frame_id = "map"
            fb.current_pose.header.stamp = self.nav.get_clock().now().to_msg()
            fb.current_pose.pose.position.x, fb.current_pose.pose.position.y = pose[0], pose[1]
            yaw_quaternion(fb.current_pose.pose.orientation, pose[2])
            fb.navigation_time = Duration(sec=int(t - started), nanosec=int((t - started) % 1 * 1e9))
            fb.distance_remaining = float(remaining)
            gh.publish_feedback(fb)

    def abort(self, gh, k, outcome, message):
        """Ends goal k as Nav2 does when it fails: ABORTED, error UNKNOWN with `message`."""
        self.goals[k - 1][2] = outcome
        self.log(f"goal {k}: {outcome} ({message})")
        result = NavigateToPose.Result()
        result.error_code = NavigateToPose.Result.UNKNOWN
        result.error_msg = message
        gh.abort()
        return result

    def restart_server(self):
        self.log("action server destroyed mid-goal")
        with self.world.lock:
            self.world.path = []
        self.server.destroy()
        time.sleep(2.0)
        self.server = self.make_server()
        self.log("action server created again")

    # ---------------------------------------------------------------- the monitor
    def on_status(self, msg):
        self.statuses.append(json.loads(msg.data))

    def on_markers(self, msg):
        for m in msg.markers:
            self.markers[m.ns] = self.markers.get(m.ns, 0) + 1
            if m.ns == "goal" and m.action == 0:
                self.marker_goals.append([m.pose.position.x, m.pose.position.y])

    def summary(self):
        last = self.statuses[-1] if self.statuses else None
        warnings = sorted({s["last_warning"] for s in self.statuses if s.get("last_warning")})
        with self.world.lock:
            explored = self.world.explored()
            free = [self.world.truth_free(x, y) for x, y, _ in self.goals]
            marker_free = [self.world.truth_free(x, y) for x, y in self.marker_goals]
        return {
            "explored": explored,
            "goals": self.goals,
            "goals_free_on_truth": all(free),
            "statuses": len(self.statuses),
            "phases": sorted({s.get("phase", "") for s in self.statuses}),
            "last": last,
            "warnings": warnings,
            "marker_namespaces": self.markers,
            "goal_markers": len(self.marker_goals),
            "goal_markers_free_on_truth": all(marker_free),
            "events": self.events,
        }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--world", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--limit", type=float, default=240.0)
    ap.add_argument("--faults", choices=["all", "none"], default="all")
    args = ap.parse_args()
    with open(args.world) as f:
        spec = json.load(f)
    rclpy.init()
    stack = Stack(args, spec)
    executor = MultiThreadedExecutor(num_threads=4)
    for n in (stack.slam, stack.nav, stack.monitor):
        executor.add_node(n)
    deadline = time.monotonic() + args.limit
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
        if stack.statuses and stack.statuses[-1].get("phase") == "done":
            stack.log("the node reports done")
            break
    with open(args.out, "w") as f:
        json.dump(stack.summary(), f, indent=1)
    executor.shutdown()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
