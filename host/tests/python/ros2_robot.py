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

The loop keeps real time as ros2_control's controller manager does: one
thread at SCHED_FIFO priority when the system permits it (taken before
rclpy starts, so the middleware's threads inherit it, and a normal-priority
build cannot preempt the loop or the threads that carry its messages), an
absolute schedule slept to, commands taken without an executor (the last
one wins, as the controller's real-time buffer keeps it), the parameter
services served every few cycles, and no garbage collection while running
(the messages and buffers are made once; what a cycle allocates is freed by
reference counting). A single thread also keeps Python's GIL out of the
loop's timing.

Usage: ros2_robot.py ROBOT_LINK_ADDR CONTROLLER SECONDS [--joints a,b]
[--states-for S] [--description FILE] [--no-parameters 1]. --joints
declares other joints than the simulated robot's (a wrong controller);
--states-for stops /joint_states after S seconds of motion, as a
broadcaster that died; --description publishes FILE on /robot_description
(transient local, as robot_state_publisher does); --no-parameters starts
the controller's node without its parameter services. Prints "ready" on
stderr once serving and "moving" at the first non-zero command, and one
JSON object on stdout at the end (SIGTERM or SECONDS): every command
received with its wall time, and how well the loop kept its schedule.
"""

import gc
import json
import math
import os
import signal
import socket
import struct
import sys
import time

host, port = sys.argv[1].rsplit(":", 1)
LINK = (host, int(port))
CONTROLLER = sys.argv[2]
SECONDS = float(sys.argv[3])
opts = dict(zip(sys.argv[4::2], sys.argv[5::2]))
# ros2_control's controller manager asks for this priority by default.
PRIORITY = 50
# The parameter services are served every this many cycles (an executor's
# turn costs about 0.3 ms of Python, too much for every 4 ms cycle).
SERVICE_EVERY = 10
# A robot-link request unanswered this long is sent again (the simulator
# answers a repeated sequence number from its cache).
RESEND_S = 0.05
# Cycles that start this much later than scheduled are listed in the report.
LATE_LISTED_S = 0.02


def real_time():
    """SCHED_FIFO for this thread and the ones it starts, or why not."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PRIORITY))
        return "SCHED_FIFO %d" % PRIORITY
    except (AttributeError, OSError) as e:
        return "normal priority (SCHED_FIFO refused: %s)" % e


# Before rclpy starts: Fast DDS's receive and event threads inherit it.
scheduling = real_time()

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray, String  # noqa: E402


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
        return values


sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.settimeout(RESEND_S)
answer = bytearray(4096)
resent = 0


def exchange(payload):
    """The robot link: RL, version 1, a postcard ToRobot, sent again until
    answered; the answer's tag and its reader after the tag."""
    global resent
    request = b"RL\x01" + payload
    for _ in range(int(2.0 / RESEND_S)):
        sock.sendto(request, LINK)
        try:
            n = sock.recv_into(answer)
        except socket.timeout:
            resent += 1
            continue
        r = Reader(memoryview(answer)[:n])
        r.at = 3
        return r.varint(), r
    raise SystemExit("the simulated robot did not answer for 2 s")


tag, r = exchange(varint(0))  # Hello
assert tag == 0, tag
dofs = r.varint()
period_s = r.varint() / 1e6
names = []
for i in range(dofs):
    tag, r = exchange(varint(1) + bytes([i]))  # DofName
    assert tag == 1 and r.byte() == i
    n = r.varint()
    names.append(bytes(r.data[r.at : r.at + n]).decode())

seq = 0
positions = [0.0] * dofs
world_us = 0
COMMAND = varint(2)
DOFS = varint(dofs)
VELOCITIES = struct.Struct("<%dd" % dofs)


def step(velocities):
    """One period of the hardware: the held velocities out, the positions back."""
    global seq, positions, world_us
    seq += 1
    tag, r = exchange(COMMAND + varint(seq) + DOFS + VELOCITIES.pack(*velocities))
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
    commands.append([time.time(), list(msg.data)])
    # forward_command_controller: a command with the wrong size is ignored.
    if len(msg.data) != len(joints) or joints != names:
        return
    held = [v if math.isfinite(v) else 0.0 for v in msg.data]
    if moved_at is None and any(v != 0.0 for v in held):
        moved_at = time.monotonic()
        print("moving", file=sys.stderr, flush=True)


subscription = controller.create_subscription(Float64MultiArray, f"/{CONTROLLER}/commands", on_command, 10)


def take_commands():
    """Every command that arrived, in order: the last one is held."""
    with subscription.handle:
        while True:
            got = subscription.handle.take_message(subscription.msg_type, subscription.raw)
            if got is None:
                return
            on_command(got[0])


states = broadcaster.create_publisher(JointState, "/joint_states", 10)
state = JointState()
state.name = names
states_for = float(opts.get("--states-for", "inf"))
silent_since = None


def cycle():
    """ros2_control's read, update, write: the latest command held, the
    hardware stepped, its state broadcast."""
    global silent_since
    take_commands()
    step(held)
    if moved_at is not None and time.monotonic() - moved_at > states_for:
        if silent_since is None:
            silent_since = time.time()
        return
    state.header.stamp.sec = world_us // 1_000_000
    state.header.stamp.nanosec = world_us % 1_000_000 * 1000
    state.position = positions
    states.publish(state)


executor = SingleThreadedExecutor()
executor.add_node(controller)
executor.add_node(broadcaster)
stop = []
signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
gc.collect()
gc.freeze()
gc.disable()
print("ready", file=sys.stderr, flush=True)
period_ns = round(period_s * 1e9)
start_ns = time.monotonic_ns()
deadline_ns = start_ns + round(SECONDS * 1e9)
next_ns = start_ns
cycles = 0
late = []
work_max_ns = 0
gap_max_ns = 0
last_ns = start_ns
while not stop and next_ns < deadline_ns:
    now = time.monotonic_ns()
    if now < next_ns:
        time.sleep((next_ns - now) / 1e9)
        now = time.monotonic_ns()
    elif now - next_ns > LATE_LISTED_S * 1e9:
        late.append([round((now - start_ns) / 1e9, 3), round((now - next_ns) / 1e6, 1)])
    cycle()
    if cycles % SERVICE_EVERY == 0:
        executor.spin_once(timeout_sec=0)
    work_max_ns = max(work_max_ns, time.monotonic_ns() - now)
    if cycles:
        gap_max_ns = max(gap_max_ns, now - last_ns)
    last_ns = now
    cycles += 1
    next_ns += period_ns
    # A cycle that started over a period late starts the schedule anew
    # rather than bursting the missed cycles.
    if next_ns < now:
        next_ns = now + period_ns
gc.enable()
print(json.dumps({
    "names": names,
    "joints": joints,
    "commands": commands,
    "silent_since": silent_since,
    "schedule": {
        "scheduling": scheduling,
        "cycles": cycles,
        # [s since the loop started, ms late]
        "late_cycles": late,
        "longest_cycle_ms": round(work_max_ns / 1e6, 2),
        "longest_gap_ms": round(gap_max_ns / 1e6, 2),
        "resent": resent,
    },
}))
controller.destroy_node()
broadcaster.destroy_node()
rclpy.shutdown()
