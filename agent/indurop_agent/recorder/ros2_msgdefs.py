"""ROS 2 message definitions as rosbag2 stores them in MCAP (schema encoding ros2msg).

Generated from protocol/ros2/**/*.idl by python3 protocol/dds/generate.py (rosbags' Typestore.generate_msgdef); do not edit.
"""

MSGDEFS = {
    "sensor_msgs/msg/JointState": "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
}
