"""Decodes every message of the MCAP file argv[1] twice, with readers we did
not write: rosbags' AnyReader and mcap-ros2-support's decoder. Prints per
topic how many each decoded, and a few decoded values to check."""
import json
import sys
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

path = Path(sys.argv[1])
out = {"rosbags": {}, "mcap_ros2": {}, "types": {}, "values": {}}

with AnyReader([path]) as reader:
    for conn, _t, raw in reader.messages():
        msg = reader.deserialize(raw, conn.msgtype)
        out["rosbags"][conn.topic] = out["rosbags"].get(conn.topic, 0) + 1
        out["types"][conn.topic] = conn.msgtype
        v = out["values"]
        if conn.topic == "/skin/cells":
            v["cloud_points"] = int(msg.width)
            v["cloud_fields"] = [f.name for f in msg.fields]
            v["cloud_bytes_ok"] = len(msg.data) == msg.width * msg.point_step == msg.row_step
        elif conn.topic == "/joint_states":
            v["joints"] = len(msg.name)
            v["positions"] = len(msg.position)
        elif conn.topic == "/tf_static":
            v["cell_frames"] = len(msg.transforms)
            v["first_frame"] = [msg.transforms[0].header.frame_id, msg.transforms[0].child_frame_id]
        elif conn.topic == "/robot_description":
            v["urdf_start"] = msg.data[:21]
        elif conn.topic == "/skin/events":
            v["marker_ns"] = sorted(set(v.get("marker_ns", [])) | {m.ns for m in msg.markers})
        elif conn.topic == "/skin/imu":
            a = msg.linear_acceleration
            v["imu_g"] = (a.x**2 + a.y**2 + a.z**2) ** 0.5 / 9.80665
        elif conn.topic == "/skin/interface":
            v["interface_bytes"] = v.get("interface_bytes", 0) + len(msg.data)

with open(path, "rb") as f:
    for _schema, channel, _message, decoded in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
        out["mcap_ros2"][channel.topic] = out["mcap_ros2"].get(channel.topic, 0) + 1

print(json.dumps(out))
