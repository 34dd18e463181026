"""Prints every message of the MCAP file argv[1] as decoded by rosbags'
AnyReader and by mcap-ros2-support, as JSON: {"rosbags": {topic: [msg]},
"mcap_ros2": {topic: [msg]}}, messages as nested dicts and lists."""
import json
import sys
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader


def plain(x):
    if hasattr(x, "tolist"):
        return x.tolist()
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, bytes):
        return list(x)
    fields = getattr(x, "__dataclass_fields__", None) or getattr(x, "__slots__", None)
    if fields is not None and not isinstance(x, (str, int, float, bool)):
        return {k: plain(getattr(x, k)) for k in fields if not k.startswith("_")}
    return x


path = Path(sys.argv[1])
out = {"rosbags": {}, "mcap_ros2": {}}
with AnyReader([path]) as reader:
    for conn, _t, raw in reader.messages():
        out["rosbags"].setdefault(conn.topic, []).append(plain(reader.deserialize(raw, conn.msgtype)))
with open(path, "rb") as f:
    for _s, channel, _m, decoded in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
        out["mcap_ros2"].setdefault(channel.topic, []).append(plain(decoded))
print(json.dumps(out))
