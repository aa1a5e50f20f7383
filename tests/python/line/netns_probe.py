"""netns_probe.py -- a DDS peer the namespace tests run inside one of their namespaces (ip netns exec):

    netns_probe.py joint-states DOMAIN INTERFACE COUNT TOPIC...   # COUNT JointStates of each topic
    netns_probe.py write DOMAIN INTERFACE TOPIC VALUE COUNT [--matched]  # std_msgs/Float64 samples

joint-states prints one JSON object: {topic: {"type": the matched writer's type name, "names":
[the joint names of every sample], "stamps": [ns]}}.  write waits for a matching reader with
--matched (else 3 s of discovery), writes COUNT samples 10 ms apart and prints how many readers
matched.  Its types are the bridge's own generated ones (the ROS 2 compatibility test has the
separate peer)."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "agent"))
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication  # noqa: E402
from cyclonedds.domain import Domain, DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from indurop_agent.dds import ros2_types  # noqa: E402
from indurop_agent.dds.bridge import QOS  # noqa: E402
from indurop_agent.dds.settings import BridgeSettings, cyclone_config  # noqa: E402


def participant(domain: int, interface: str) -> DomainParticipant:
    Domain(domain, cyclone_config(BridgeSettings(domain_id=domain, interface=interface)))
    return DomainParticipant(domain)


def joint_states(domain: int, interface: str, count: int, topics: list[str], timeout_s: float = 60) -> dict:
    dp = participant(domain, interface)
    readers = {t: DataReader(dp, Topic(dp, t, ros2_types.JointState), QOS["default"]) for t in topics}
    seen = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    out = {t: {"type": "", "names": [], "stamps": []} for t in topics}
    deadline = time.monotonic() + timeout_s
    while any(len(o["stamps"]) < count for o in out.values()) and time.monotonic() < deadline:
        for w in seen.take(N=64):
            if getattr(w, "topic_name", None) in out:
                out[w.topic_name]["type"] = w.type_name
        for t, r in readers.items():
            for s in r.take(N=64):
                if isinstance(s, ros2_types.JointState) and len(out[t]["stamps"]) < count:
                    out[t]["names"].append(list(s.name))
                    out[t]["stamps"].append(s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec)
        time.sleep(0.002)
    return out


def write(domain: int, interface: str, topic: str, value: float, count: int, matched: bool) -> int:
    dp = participant(domain, interface)
    w = DataWriter(dp, Topic(dp, topic, ros2_types.Float64), QOS["default"])
    deadline = time.monotonic() + (30 if matched else 3)
    while time.monotonic() < deadline:
        if matched and w.get_publication_matched_status().current_count:
            break
        time.sleep(0.05)
    for _ in range(count):
        w.write(ros2_types.Float64(data=value))
        time.sleep(0.01)
    time.sleep(0.5)  # reliable: let the last ones go out
    return w.get_publication_matched_status().current_count


def main(argv: list[str]) -> int:
    kind, domain, interface = argv[0], int(argv[1]), argv[2]
    if kind == "joint-states":
        print(json.dumps(joint_states(domain, interface, int(argv[3]), argv[4:])))
    elif kind == "write":
        print(
            json.dumps(
                {"matched": write(domain, interface, argv[3], float(argv[4]), int(argv[5]), "--matched" in argv)}
            )
        )
    else:
        print(f"netns_probe.py: unknown {kind!r}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
