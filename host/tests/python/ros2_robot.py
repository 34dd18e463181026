"""A ros2_control robot as rclpy sees one, moving the simulated skin.

Two nodes with the semantics of ros2_control's controllers:
`joint_state_broadcaster` publishes sensor_msgs/JointState on
/joint_states, and CONTROLLER (a forward_command_controller on the velocity
interface) declares a `joints` parameter, takes std_msgs/Float64MultiArray
on /CONTROLLER/commands and holds the last one. The hardware is `skin
sim-endpoint --pace lockstep`'s robot link: the loop runs at the simulated
robot's own control period (the link tells it: 4 ms, 250 Hz), and every
cycle the held velocities go to it, one period of the world passes, and
its positions come back. /joint_states are stamped with the world's clock,
as a simulated robot's are under use_sim_time, so a loaded machine slows
the world and its stamps together instead of breaking their agreement.

Usage: ros2_robot.py ROBOT_LINK_ADDR CONTROLLER SECONDS [--joints a,b]
[--states-for S] [--description FILE] [--no-parameters 1]. --joints
declares other joints than the simulated robot's (a wrong controller);
--states-for stops /joint_states after S seconds of motion, as a
broadcaster that died; --description publishes FILE on /robot_description
(transient local, as robot_state_publisher does); --no-parameters starts
the controller's node without its parameter services. Prints "ready" on
stderr once serving and "moving" at the first non-zero command, and one
JSON object on stdout at the end (SIGTERM or SECONDS): every command
received with its wall time.
"""

import json
import math
import signal
import socket
import struct
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Float64MultiArray, String

host, port = sys.argv[1].rsplit(":", 1)
LINK = (host, int(port))
CONTROLLER = sys.argv[2]
SECONDS = float(sys.argv[3])
opts = dict(zip(sys.argv[4::2], sys.argv[5::2]))


def varint(n):
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


class Reader:
    def __init__(self, data):
        self.data, self.at = data, 0

    def byte(self):
        self.at += 1
        return self.data[self.at - 1]

    def varint(self):
        n, shift = 0, 0
        while True:
            b = self.byte()
            n |= (b & 0x7F) << shift
            shift += 7
            if not b & 0x80:
                return n

    def f64s(self):
        n = self.varint()
        values = struct.unpack_from("<%dd" % n, self.data, self.at)
        self.at += 8 * n
        return list(values)


sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.settimeout(1.0)


def exchange(payload):
    """The robot link: RL, version 1, a postcard ToRobot; the answer's reader after its tag."""
    sock.sendto(b"RL\x01" + payload, LINK)
    r = Reader(sock.recvfrom(4096)[0])
    r.at = 3
    return r.varint(), r


tag, r = exchange(varint(0))  # Hello
assert tag == 0, tag
dofs = r.varint()
period_s = r.varint() / 1e6
names = []
for i in range(dofs):
    tag, r = exchange(varint(1) + bytes([i]))  # DofName
    assert tag == 1 and r.byte() == i
    n = r.varint()
    names.append(r.data[r.at : r.at + n].decode())

seq = 0
positions = [0.0] * dofs
world_us = 0


def step(velocities):
    """One period of the hardware: the held velocities out, the positions back."""
    global seq, positions, world_us
    seq += 1
    payload = varint(2) + varint(seq) + varint(dofs) + struct.pack("<%dd" % dofs, *velocities)
    tag, r = exchange(payload)
    if tag == 2:  # State
        r.varint()
        world_us = r.varint()
        positions = r.f64s()


step([0.0] * dofs)
rclpy.init()
joints = opts["--joints"].split(",") if "--joints" in opts else names
controller = rclpy.create_node(CONTROLLER, parameter_overrides=[Parameter("joints", value=joints)],
                               automatically_declare_parameters_from_overrides=True,
                               start_parameter_services="--no-parameters" not in opts)
broadcaster = rclpy.create_node("joint_state_broadcaster")
if "--description" in opts:
    with open(opts["--description"]) as f:
        urdf = String(data=f.read())
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    description = broadcaster.create_publisher(String, "/robot_description", latched)
    description.publish(urdf)
held = [0.0] * dofs
commands = []
moved_at = None


def on_command(msg):
    global held, moved_at
    now = time.time()
    commands.append([now, list(msg.data)])
    # forward_command_controller: a command with the wrong size is ignored.
    if len(msg.data) != len(joints) or joints != names:
        return
    held = [v if math.isfinite(v) else float("nan") for v in msg.data]
    if moved_at is None and any(v != 0.0 for v in held):
        moved_at = time.monotonic()
        print("moving", file=sys.stderr, flush=True)


controller.create_subscription(Float64MultiArray, f"/{CONTROLLER}/commands", on_command, 10)
states = broadcaster.create_publisher(JointState, "/joint_states", 10)
states_for = float(opts.get("--states-for", "inf"))
silent_since = None


def tick():
    global silent_since
    step([v if math.isfinite(v) else 0.0 for v in held])
    if moved_at is not None and time.monotonic() - moved_at > states_for:
        if silent_since is None:
            silent_since = time.time()
        return
    msg = JointState()
    msg.header.stamp.sec = world_us // 1_000_000
    msg.header.stamp.nanosec = world_us % 1_000_000 * 1000
    msg.name = names
    msg.position = positions
    states.publish(msg)


broadcaster.create_timer(period_s, tick)
executor = SingleThreadedExecutor()
executor.add_node(controller)
executor.add_node(broadcaster)
stop = []
signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
print("ready", file=sys.stderr, flush=True)
deadline = time.monotonic() + SECONDS
while not stop and time.monotonic() < deadline:
    executor.spin_once(timeout_sec=0.01)
print(json.dumps({"names": names, "joints": joints, "commands": commands, "silent_since": silent_since}))
controller.destroy_node()
broadcaster.destroy_node()
rclpy.shutdown()
