"""Watches the skin's live Foxglove view as a Foxglove client would, and
prints what it got as JSON.

argv[1]: the view's WebSocket URL (ws://127.0.0.1:PORT); argv[2]: seconds
to wait at most. The client speaks Foxglove's WebSocket protocol with the
`websockets` package, offering both its names (`foxglove.sdk.v1`, which the
Foxglove SDK's server accepts, and the older `foxglove.websocket.v1`): it reads serverInfo and advertise, subscribes to
every channel, then sends what a broken client might (text that is not
JSON, a subscribe of the wrong shape, an unknown op, binary junk) and
keeps listening. Binary messageData (opcode 1: subscription id, log time,
payload) is decoded with the schema the server advertised: protobuf
channels through google.protobuf's descriptor pool built from the
advertised FileDescriptorSet, JSON channels with json. It stops when the
server closes the connection (the run ended) or the time is up."""
import base64
import json
import math
import struct
import sys
import time

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

URL, SECONDS = sys.argv[1], float(sys.argv[2])
deadline = time.monotonic() + SECONDS


def decoder(channel):
    """A function from payload bytes to a Python value, per the advertised schema."""
    if channel["encoding"] == "json":
        return lambda payload: json.loads(payload)
    assert channel["encoding"] == "protobuf", channel
    assert channel["schemaEncoding"] == "protobuf", channel
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"])).file
    pool = descriptor_pool.DescriptorPool()
    pending = list(files)
    while pending:  # dependencies first, whatever order they came in
        left = []
        for f in pending:
            try:
                pool.Add(f)
            except TypeError:
                left.append(f)
        if len(left) == len(pending):
            raise SystemExit(f"cannot load the schema of {channel['topic']}")
        pending = left
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))
    return cls.FromString


def open_socket():
    while True:
        try:
            return connect(URL, subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"], open_timeout=5, max_size=None)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


ws = open_socket()
out = {"subprotocol": ws.subprotocol, "channels": {}, "topics": {}, "grasp": [], "logs": [], "after_junk": 0}
channels = {}
subscribed = {}
junk_sent = False
scene = {"messages": 0, "best": None, "red_max": 0, "blue_max": 0, "contacts_max": 0}
robot = {"messages": 0, "frames_max": 0, "bone_points_max": 0}
tf = {"messages": 0, "frames_max": 0, "parents": []}


def cells_of(update):
    """The cells entity of a SceneUpdate as plain values."""
    for e in update.entities:
        if e.id == "cells":
            meta = {kv.key: kv.value for kv in e.metadata}
            cubes = [
                {
                    "xyz": [c.pose.position.x, c.pose.position.y, c.pose.position.z],
                    "rgb": [c.color.r, c.color.g, c.color.b],
                    "height": c.size.z,
                }
                for c in e.cubes
            ]
            ids = [int(i) for i in meta["ids"].split(",")] if meta.get("ids") else []
            force = [float(f) for f in meta["force"].split(",")] if meta.get("force") else []
            return {"frame": e.frame_id, "ids": ids, "force": force, "cubes": cubes}
    return None


def spread(cubes):
    pts = [c["xyz"] for c in cubes]
    if not pts:
        return 0.0
    return max(math.dist(a, b) for a in pts[:50] for b in pts)


try:
    while time.monotonic() < deadline:
        try:
            msg = ws.recv(timeout=max(0.1, deadline - time.monotonic()))
        except TimeoutError:
            break
        if isinstance(msg, str):
            m = json.loads(msg)
            op = m.get("op")
            if op == "serverInfo":
                out["server_info"] = {"name": m.get("name"), "capabilities": m.get("capabilities")}
            elif op == "advertise":
                subs = []
                for c in m["channels"]:
                    channels[c["id"]] = (c["topic"], decoder(c))
                    out["channels"][c["topic"]] = {"encoding": c["encoding"], "schemaName": c["schemaName"]}
                    sid = len(subscribed) + 1
                    subscribed[sid] = c["id"]
                    subs.append({"id": sid, "channelId": c["id"]})
                ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
            elif op == "status":
                out.setdefault("status", []).append(m.get("message"))
            continue
        if not junk_sent and subscribed:
            # A broken client: the server must say so or ignore it, and go on.
            ws.send("this is not JSON {")
            ws.send(json.dumps({"op": "subscribe", "subscriptions": "all of them"}))
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": "x", "channelId": -1}]}))
            ws.send(json.dumps({"op": "no such op"}))
            ws.send(b"\xff\x00\x01junk")
            junk_sent = True
        elif junk_sent:
            out["after_junk"] += 1
        assert msg[0] == 1, f"opcode {msg[0]}"
        sid, _log_time = struct.unpack_from("<IQ", msg, 1)
        topic, decode = channels[subscribed[sid]]
        value = decode(msg[13:])
        out["topics"][topic] = out["topics"].get(topic, 0) + 1
        if topic == "/skin/scene":
            scene["messages"] += 1
            cells = cells_of(value)
            if cells is not None:
                red = sum(1 for c in cells["cubes"] if c["rgb"][0] > 0.6 and c["rgb"][2] < 0.2)
                blue = sum(1 for c in cells["cubes"] if c["rgb"][2] > 0.65 and c["rgb"][0] < 0.55)
                scene["red_max"] = max(scene["red_max"], red)
                scene["blue_max"] = max(scene["blue_max"], blue)
                best = scene["best"]
                if best is None or (len(cells["cubes"]), spread(cells["cubes"])) >= (
                    len(best["cubes"]),
                    best["spread_m"],
                ):
                    cells["spread_m"] = spread(cells["cubes"])
                    scene["best"] = cells
            contacts = [e for e in value.entities if e.id == "contacts"]
            if contacts:
                scene["contacts_max"] = max(scene["contacts_max"], len(contacts[0].spheres))
        elif topic == "/skin/robot":
            robot["messages"] += 1
            e = value.entities[0]
            robot["frames_max"] = max(robot["frames_max"], len(e.spheres))
            robot["bone_points_max"] = max(robot["bone_points_max"], sum(len(l.points) for l in e.lines))
        elif topic == "/tf":
            tf["messages"] += 1
            tf["frames_max"] = max(tf["frames_max"], len(value.transforms))
            tf["parents"] = sorted({t.parent_frame_id for t in value.transforms})
        elif topic == "/skin/log":
            if len(out["logs"]) < 2000:
                out["logs"].append(value.message)
        elif topic == "/skin/grasp":
            out["grasp"].append(value)
except ConnectionClosed:
    out["closed_by_server"] = True

best = scene["best"]
if best is not None:
    best["cubes"] = best["cubes"][:3] + [{"count": len(best["cubes"])}]
out["scene"] = scene
out["robot"] = robot
out["tf"] = tf
out["logs"] = {"count": len(out["logs"]), "first": out["logs"][:5], "grasp": [l for l in out["logs"] if l.startswith("grasp")][:3]}
print(json.dumps(out))
