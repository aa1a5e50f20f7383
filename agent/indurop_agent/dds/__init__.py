"""The DDS bridge (docs/dds.md): the controller on Cyclone DDS as ROS 2 sees it.

bridge.py is the process (`indurop-dds-bridge`), settings.py its settings and Cyclone DDS
configuration, bridge_file.py a set's dds.json; ros2_types.py and bridge_schema.py are generated
by protocol/dds/generate.py from protocol/ros2/**/*.idl and protocol/dds/bridge.schema.json.
"""
