"""An rclpy peer of the fitslam node on ROS 2 Jazzy's default RMW (rmw_fastrtps_cpp): publishes a
latched nav_msgs/OccupancyGrid on /map as map_server does, reads the node's latched JSON status
on /fitslam/status, and once the node reports its map, sends `stop` on /fitslam/control (std_msgs/String).
Prints one JSON line: how many statuses arrived and the last one. Argument: time limit, seconds."""

import json
import sys
import time

import rclpy
from nav_msgs.msg import OccupancyGrid
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


def main() -> None:
    limit_s = float(sys.argv[1])
    rclpy.init()
    node = Node("rclpy_peer")
    latched = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST
    )
    statuses = []
    node.create_subscription(String, "/fitslam/status", lambda m: statuses.append(m.data), latched)
    map_pub = node.create_publisher(OccupancyGrid, "/map", latched)
    control_pub = node.create_publisher(String, "/fitslam/control", 10)
    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.resolution = 0.1
    grid.info.width = 40
    grid.info.height = 30
    grid.info.origin.orientation.w = 1.0
    grid.data = [0] * (40 * 30)
    map_pub.publish(grid)
    t0 = time.time()
    last_stop = -1.0
    while time.time() - t0 < limit_s:
        rclpy.spin_once(node, timeout_sec=0.05)
        status = json.loads(statuses[-1]) if statuses else {}
        if status.get("phase") == "done":
            break
        # The node has the map: ask it to stop (again every second until it is done).
        if status.get("map_cells") == [40, 30] and time.time() - last_stop >= 1.0:
            control_pub.publish(String(data="stop"))
            last_stop = time.time()
    print(json.dumps({"statuses": len(statuses), "last": json.loads(statuses[-1]) if statuses else None}))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
