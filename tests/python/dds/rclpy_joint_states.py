"""rclpy_joint_states.py -- a ROS 2 node (rclpy, run by .venv-ros2's Python) that prints the first
COUNT sensor_msgs/JointState messages of TOPIC as JSON lines, or nothing after TIMEOUT_S.

    python rclpy_joint_states.py TOPIC COUNT TIMEOUT_S
"""

import json
import sys
import time

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState

topic, count, timeout_s = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rclpy.init()
node = Node("indurop_dds_check")
got = []
node.create_subscription(JointState, topic, got.append, 10)  # ROS 2's default QoS
end = time.monotonic() + timeout_s
while time.monotonic() < end and len(got) < count:
    rclpy.spin_once(node, timeout_sec=0.1)
for m in got[:count]:
    print(
        json.dumps(
            {
                "sec": m.header.stamp.sec,
                "nanosec": m.header.stamp.nanosec,
                "name": list(m.name),
                "position": list(m.position),
            }
        )
    )
node.destroy_node()
rclpy.shutdown()
