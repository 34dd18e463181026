"""Loads an MJCF model with MuJoCo and prints, as JSON, what it compiled:
its joints (name, type, axis in the body frame, range), its actuators, and
every body's world pose (x y z, quaternion w x y z) after mj_kinematics at
each pose of the poses file ({"poses": [{joint name: position}]}); then,
after 2 s of simulation with the servos holding the first pose, how far each
servo's joint is from its target ("hold_error") and, for each mimic
({"follow": [[mimic, master]]}), the mimic's and the master's positions."""

import json
import sys

import mujoco

model = mujoco.MjModel.from_xml_path(sys.argv[1])
request = json.load(open(sys.argv[2]))
data = mujoco.MjData(model)
types = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge", int(mujoco.mjtJoint.mjJNT_SLIDE): "slide"}
out = {
    "timestep": model.opt.timestep,
    "integrator": int(model.opt.integrator),
    "joints": [
        {
            "name": model.joint(j).name,
            "type": types.get(int(model.jnt_type[j]), "other"),
            "axis": list(model.jnt_axis[j]),
            "limited": bool(model.jnt_limited[j]),
            "range": list(model.jnt_range[j]),
        }
        for j in range(model.njnt)
    ],
    "actuators": [
        {"name": model.actuator(a).name, "forcerange": list(model.actuator_forcerange[a])} for a in range(model.nu)
    ],
    "poses": [],
}


def set_pose(pose):
    for name, q in pose.items():
        data.qpos[model.joint(name).qposadr[0]] = q


for pose in request["poses"]:
    mujoco.mj_resetData(model, data)
    set_pose(pose)
    mujoco.mj_kinematics(model, data)
    out["poses"].append(
        {model.body(b).name: list(data.xpos[b]) + list(data.xquat[b]) for b in range(model.nbody)}
    )

# Two seconds with the servos holding the first pose against gravity.
mujoco.mj_resetData(model, data)
first = request["poses"][0]
set_pose(first)
joint_of = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[a][0]) for a in range(model.nu)]
for a in range(model.nu):
    data.ctrl[a] = first[joint_of[a]]
for _ in range(int(2.0 / model.opt.timestep)):
    mujoco.mj_step(model, data)
q = lambda name: float(data.qpos[model.joint(name).qposadr[0]])
out["hold_error"] = {name: abs(q(name) - first[name]) for name in joint_of}
out["follow"] = [[q(mimic), q(master)] for mimic, master in request["follow"]]
print(json.dumps(out))
