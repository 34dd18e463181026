"""Prints the last /tf_static and /robot_description of the MCAP file
argv[1], as rosbags decodes them: {"frames": [[parent, child, [x, y, z]]],
"description_skin_frames": N}."""
import json
import sys
from pathlib import Path

from rosbags.highlevel import AnyReader

last = {}
with AnyReader([Path(sys.argv[1])]) as reader:
    wanted = [c for c in reader.connections if c.topic in ("/tf_static", "/robot_description")]
    for conn, _t, raw in reader.messages(connections=wanted):
        last[conn.topic] = reader.deserialize(raw, conn.msgtype)
tf = last["/tf_static"]
frames = [
    [t.header.frame_id, t.child_frame_id, [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z]]
    for t in tf.transforms
]
print(json.dumps({"frames": frames, "description_skin_frames": last["/robot_description"].data.count("<link name=\"skin_cell_")}))
