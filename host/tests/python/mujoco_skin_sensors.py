"""Loads a model wearing a calibrated skin (robot_with_skin.xml) with MuJoCo,
lets it settle for 1 s under its servos, and prints every skin cell as JSON:
{"skin_cell_<ID>": {"body", "pos", "quat", "acc", "range", "touch"}}."""

import json
import sys

import mujoco

model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
for _ in range(int(1.0 / model.opt.timestep)):
    mujoco.mj_step(model, data)


def reading(name):
    sensor = model.sensor(name)
    return [float(v) for v in data.sensordata[sensor.adr[0] : sensor.adr[0] + sensor.dim[0]]]


cells = {}
for s in range(model.nsite):
    name = model.site(s).name
    if name.startswith("skin_cell_") and ":" not in name:
        cells[name] = {
            "body": model.body(model.site_bodyid[s]).name,
            "pos": [float(v) for v in model.site_pos[s]],
            "quat": [float(v) for v in model.site_quat[s]],
            "acc": reading(f"{name}:acc"),
            "range": reading(f"{name}:range")[0],
            "touch": [reading(f"{name}:touch{k}")[0] for k in range(3)],
        }
print(json.dumps(cells))
