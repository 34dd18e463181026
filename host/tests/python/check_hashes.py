"""Prints the RIHS01 hash rosbags computes for every type named in the JSON
file argv[1] ({type: [our hash, our ros2msg text]}): from its built-in Jazzy
type store when it has the type, otherwise from our definition text."""
import json
import sys

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ours = json.load(open(sys.argv[1]))
store = get_typestore(Stores.ROS2_JAZZY)
theirs = {}
for name, (_, text) in ours.items():
    if name not in store.fielddefs:
        store.register(get_types_from_msg(text, name))
        source = "our definition"
    else:
        source = "rosbags jazzy store"
    theirs[name] = [store.hash_rihs01(name), source]
print(json.dumps(theirs))
