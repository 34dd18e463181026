"""Reads a URDF with ROS's urdf_parser_py and prints every skin cell's
fixed frame as JSON: {"links": N, "cells": {"ID": {"parent", "xyz", "rpy"}}}."""

import json
import sys

from urdf_parser_py.urdf import URDF

robot = URDF.from_xml_string(open(sys.argv[1]).read())
cells = {}
for joint in robot.joints:
    if joint.child.startswith("skin_cell_"):
        if joint.type != "fixed":
            sys.exit(f"{joint.name} is {joint.type}, not fixed")
        cells[joint.child[len("skin_cell_"):]] = {
            "parent": joint.parent,
            "xyz": list(joint.origin.xyz),
            "rpy": list(joint.origin.rpy),
        }
print(json.dumps({"links": len(robot.links), "cells": cells}))
