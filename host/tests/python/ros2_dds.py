"""ROS 2 over DDS as a stock Jazzy sees it: an rclpy node on Fast DDS
(rmw_fastrtps_cpp, from the PyPI wheels) subscribes to the skin's topics
while `skin demo --ros2` runs, reads the graph (the node /skin, its
publishers, their types and QoS), and a second node joins late with a
transient-local subscription to /robot_description.

/tf_static is checked in the graph only: its type, tf2_msgs/TFMessage, has
no wheel, and Fast DDS matches a reader to a writer by type name.

Usage: ros2_dds.py SECONDS COUNT STREAM... Says "ready" on stderr once
its subscriptions exist (the test starts the demo then: started side by
side, rclpy came up late on a cold machine and missed part of the quick
demo). Listens until every volatile topic has been heard, each
STREAM topic COUNT times, and the late joiner has its description; or
until the demo's node, once seen, has left the graph; or SECONDS have
passed. Prints one JSON object, with what was still missing.
"""

import json
import sys
import time

import rclpy
import rclpy.utilities
from rclpy.node import NodeNameNonExistentError
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import Imu, JointState, PointCloud2
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

SECONDS = float(sys.argv[1])
COUNT = int(sys.argv[2])
STREAMS = sys.argv[3:]
VOLATILE = {
    "/skin/cells": PointCloud2,
    "/skin/imu": Imu,
    "/skin/events": MarkerArray,
    "/joint_states": JointState,
}
LATCHED = ["/tf_static", "/robot_description"]


def describe(topic, msg):
    if topic == "/skin/cells":
        return {
            "points": msg.width * msg.height,
            "fields": [f.name for f in msg.fields],
            "frame": msg.header.frame_id,
            "point_step": msg.point_step,
            "bytes": len(msg.data),
        }
    if topic == "/joint_states":
        return {"joints": len(msg.name), "positions": len(msg.position), "finite": all(p == p for p in msg.position)}
    if topic == "/robot_description":
        return {"start": msg.data[:21], "end": msg.data[-9:]}
    if topic == "/skin/events":
        return {"markers": len(msg.markers), "ns": sorted({m.ns for m in msg.markers})}
    if topic == "/skin/imu":
        a = msg.linear_acceleration
        return {"frame": msg.header.frame_id, "g": (a.x**2 + a.y**2 + a.z**2) ** 0.5 / 9.80665}
    return {}


cells_latency_ms = []  # /skin/cells: receipt in rclpy's callback minus the header stamp


def keep(into, topic):
    def on_message(msg):
        if topic == "/skin/cells" and into is live:
            stamp = msg.header.stamp.sec * 1e9 + msg.header.stamp.nanosec
            cells_latency_ms.append((time.time_ns() - stamp) / 1e6)
        entry = into.setdefault(topic, {"count": 0, "first": describe(topic, msg), "stamps": []})
        entry["count"] += 1
        if len(entry["stamps"]) < 5:
            entry["stamps"].append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 if hasattr(msg, "header") else None)
        entry["last"] = describe(topic, msg)

    return on_message


def qos_text(info):
    q = info.qos_profile
    return {
        "reliability": q.reliability.name,
        "durability": q.durability.name,
        "node": info.node_namespace.rstrip("/") + "/" + info.node_name,
        "type": info.topic_type,
    }


rclpy.init()
rmw = rclpy.utilities.get_rmw_implementation_identifier()
node = rclpy.create_node("skin_check")
executor = SingleThreadedExecutor()
executor.add_node(node)
live = {}
reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
# /skin/imu as REP 2003 has sensor data subscribed: best effort, from a
# reliable publisher. Subscribed reliably, a burst of 74 (a message per
# cell) racing the match stalled the stream for good in 1 of 24 runs.
SENSOR_DATA = {"/skin/imu"}
for topic, ty in VOLATILE.items():
    qos = qos_profile_sensor_data if topic in SENSOR_DATA else reliable
    node.create_subscription(ty, topic, keep(live, topic), qos)

latched_qos = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    history=HistoryPolicy.KEEP_LAST,
)

deadline = time.monotonic() + SECONDS
print("ready", file=sys.stderr, flush=True)


def publishers_of(topic):
    return [i for i in node.get_publishers_info_by_topic(topic) if i.node_name == "skin"]


def graph_now():
    """The graph while /skin is in it, else None."""
    try:
        return {
            "nodes": sorted(ns.rstrip("/") + "/" + n for n, ns in node.get_node_names_and_namespaces()),
            "skin_publishers": sorted(
                [t, types] for t, types in node.get_publisher_names_and_types_by_node("skin", "/")
            ),
            "qos": {t: [qos_text(i) for i in publishers_of(t)] for t in list(VOLATILE) + LATCHED},
        }
    except NodeNameNonExistentError:
        return None


# The graph once every latched topic has a publisher of /skin: that is
# when the demo has published them, and when the late joiner joins.
while time.monotonic() < deadline and not all(publishers_of(t) for t in LATCHED):
    executor.spin_once(timeout_sec=0.05)
seen = graph_now()
late_node = rclpy.create_node("skin_late")
late = {}
late_node.create_subscription(String, "/robot_description", keep(late, "/robot_description"), latched_qos)
executor.add_node(late_node)

# A stream, not one burst: /skin/imu comes as one message per cell at
# each cloud, so heard once it may be a few messages of a single burst.
def missing():
    few = [t for t in VOLATILE if live.get(t, {}).get("count", 0) < (COUNT if t in STREAMS else 1)]
    return few + ([] if "/robot_description" in late else ["late /robot_description"])


def demo_over():
    return seen is not None and ("skin", "/") not in node.get_node_names_and_namespaces()


# The graph is looked at again every second while listening, so that it
# is the one of the demo at its busiest.
looked = time.monotonic()
while time.monotonic() < deadline and missing() and not demo_over():
    executor.spin_once(timeout_sec=0.05)
    if time.monotonic() - looked > 1.0:
        seen, looked = graph_now() or seen, time.monotonic()
# A moment more: a second copy of a latched message would arrive now.
settle = time.monotonic() + 0.5
while time.monotonic() < settle:
    executor.spin_once(timeout_sec=0.05)

graph = graph_now() or seen or {"nodes": [], "skin_publishers": [], "qos": {}}
print(json.dumps({
    "rmw": rmw, "live": live, "late": late, "graph": graph, "missing": missing(),
    "cells_latency_ms": sorted(cells_latency_ms),
}))
late_node.destroy_node()
node.destroy_node()
rclpy.shutdown()
