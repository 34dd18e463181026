"""Subscribes to the skin's live ROS 2 topics as a ROS 2 machine's Zenoh
peer would, and prints what it got as JSON.

argv[1]: the skin's Zenoh endpoint (tcp/127.0.0.1:PORT); argv[2]: seconds
to wait at most. A peer session with multicast scouting off connects to
it; a subscriber on `<domain>/**` takes every data sample (rmw_zenoh's key
expressions `<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<hash>`), rosbags
decodes each payload as the type the key names, and the attachment is read
as rmw_zenoh writes it. A liveliness subscriber collects the graph's
tokens. Once the publishers of /robot_description and /tf_static have
announced themselves (the skin declares a publisher with its first
message), a second, late-joining session asks for them with zenoh-ext's
advanced subscriber (history, late publisher detection), as an rmw_zenoh
transient-local subscription does; what it gets is reported apart."""
import json
import struct
import sys
import threading
import time

import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

ENDPOINT, SECONDS = sys.argv[1], float(sys.argv[2])
LATCHED = ["/tf_static", "/robot_description"]
WANTED = ["/skin/cells", "/joint_states", "/skin/imu", "/skin/events"] + LATCHED


def peer():
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("connect/endpoints", json.dumps([ENDPOINT]))
    return zenoh.open(conf)


def split(key):
    """(domain, topic, ROS type name, hash) of an rmw_zenoh data key."""
    parts = key.split("/")
    pkg, kind, _, name = parts[-2].split("::")
    return parts[0], "/" + "/".join(parts[1:-2]), f"{pkg}/{kind}/{name.rstrip('_')}", parts[-1]


store = get_typestore(Stores.ROS2_JAZZY)
lock = threading.Lock()
samples = {}  # key -> [count, first payload, attachments of the first few]
late = {}  # the same, of what the late joiner got
tokens = set()
cells_latency_ms = []  # /skin/cells: receipt here minus the source time in the attachment


def keep(into):
    def on_sample(sample):
        key = str(sample.key_expr)
        attachment = sample.attachment.to_bytes() if sample.attachment is not None else None
        if into is samples and "/skin/cells/" in key and attachment is not None and len(attachment) >= 16:
            cells_latency_ms.append((time.time_ns() - struct.unpack_from("<q", attachment, 8)[0]) / 1e6)
        with lock:
            entry = into.setdefault(key, [0, sample.payload.to_bytes(), []])
            entry[0] += 1
            if len(entry[2]) < 5:
                entry[2].append(attachment)

    return on_sample


def on_token(sample):
    if sample.kind == zenoh.SampleKind.PUT:
        with lock:
            tokens.add(str(sample.key_expr))


def heard(what):
    with lock:
        return {split(k)[1] for k in what}


def announced(topic):
    mangled = "/" + topic.replace("/", "%") + "/"
    with lock:
        return any("/MP/" in t and mangled in t for t in tokens)


session = peer()
subscriber = session.declare_subscriber("0/**", keep(samples))
liveliness = session.liveliness().declare_subscriber("@ros2_lv/**", on_token, history=True)

deadline = time.monotonic() + SECONDS
while time.monotonic() < deadline and not all(announced(t) for t in LATCHED):
    time.sleep(0.05)
peers = [str(z) for z in session.info.peers_zid()]

late_session = peer()
late_subscribers = [
    zenoh.ext.declare_advanced_subscriber(
        late_session,
        f"0{topic}/**",
        keep(late),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True),
    )
    for topic in LATCHED
]
while time.monotonic() < deadline and not (
    all(t in heard(samples) for t in WANTED if t not in LATCHED) and all(t in heard(late) for t in LATCHED)
):
    time.sleep(0.05)

with lock:
    snapshot = {k: (v[0], v[1], list(v[2])) for k, v in samples.items()}
    late_snapshot = {k: (v[0], v[1], list(v[2])) for k, v in late.items()}
    got_tokens = sorted(tokens)


def describe(snapshot):
    topics = {}
    for key, (count, payload, attachments) in snapshot.items():
        domain, topic, ros_type, hash_text = split(key)
        msg = store.deserialize_cdr(payload, ros_type)
        values = {}
        if ros_type == "sensor_msgs/msg/PointCloud2":
            values = {"points": msg.width * msg.height, "fields": [f.name for f in msg.fields], "frame": msg.header.frame_id}
        elif ros_type == "sensor_msgs/msg/JointState":
            values = {"joints": len(msg.name), "positions": len(msg.position)}
        elif ros_type == "tf2_msgs/msg/TFMessage":
            values = {"frames": len(msg.transforms), "first": [msg.transforms[0].header.frame_id, msg.transforms[0].child_frame_id]}
        elif ros_type == "std_msgs/msg/String":
            values = {"start": msg.data[:21]}
        elif ros_type == "visualization_msgs/msg/MarkerArray":
            values = {"markers": len(msg.markers)}
        elif ros_type == "sensor_msgs/msg/Imu":
            a = msg.linear_acceleration
            values = {"frame": msg.header.frame_id, "g": (a.x**2 + a.y**2 + a.z**2) ** 0.5 / 9.80665}
        decoded = []
        for att in attachments:
            if att is None or len(att) != 33 or att[16] != 16:
                decoded.append(None)
                continue
            seq, stamp = struct.unpack_from("<qq", att)
            decoded.append({"seq": seq, "stamp_ns": stamp, "gid": att[17:].hex()})
        topics.setdefault(topic, []).append(
            {
                "key": key,
                "domain": domain,
                "type": ros_type,
                "hash": hash_text,
                "rosbags_hash": store.hash_rihs01(ros_type),
                "count": count,
                "values": values,
                "attachments": decoded,
            }
        )
    return topics


print(
    json.dumps(
        {
            "topics": describe(snapshot),
            "late": describe(late_snapshot),
            "tokens": got_tokens,
            "peers": peers,
            "cells_latency_ms": sorted(cells_latency_ms),
        }
    )
)
for s in late_subscribers:
    s.undeclare()
subscriber.undeclare()
liveliness.undeclare()
late_session.close()
session.close()
