#!/usr/bin/env python3
"""A plain Eclipse Cyclone DDS participant (the `cyclonedds` package from PyPI, the C library inside its wheel)
standing where an rmw_cyclonedds_cpp node would: ROS 2's topic names (`rt/...`), rosidl's DDS type names
(`pkg::msg::dds_::Name_`), rmw's QoS (reliable, volatile, keep-last 10; the state topics transient-local depth
1) and Jazzy's `typehash=` USER_DATA where a test asks for it. For tests/cyclone.rs.

Each command prints JSON lines on stdout. Cyclone DDS writes what it finds wrong with a peer's packets ("malformed
packet received from vendor ...") to the C library's stderr: fd 2 is caught in a file, and the last line printed
is {"cyclone_log": [lines]} for the test to read.

    cyclone_peer.py drive RESPONSE     # start, then interrupt RESPONSE; read its signals; then its state late
    cyclone_peer.py listen EVENT N     # read N of EVENT's triggers
    cyclone_peer.py level TOPIC        # geometry_msgs/Point on TOPIC: a short payload, another definition, a good one
    cyclone_peer.py pub_once TOPIC     # one std_msgs/Empty, as `ros2 topic pub --once` on rmw_cyclonedds_cpp does
    cyclone_peer.py manage MANAGER SOURCE TARGET   # the manager's connect and disconnect services, as a client
                                                   # on rmw_cyclonedds_cpp calls them
"""
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, int64, uint8, uint32, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

TIMEOUT = 20.0

# Cyclone's own log lines: fd 2 into a file, read back at the end
_LOG = tempfile.TemporaryFile(mode="w+b")
_STDERR = os.dup(2)
os.dup2(_LOG.fileno(), 2)


def out(**kv: object) -> None:
    print(json.dumps(kv), flush=True)


def finish(code: int = 0) -> None:
    os.dup2(_STDERR, 2)
    _LOG.seek(0)
    lines = _LOG.read().decode(errors="replace").splitlines()
    for line in lines:
        print(f"[cyclone] {line}", file=sys.stderr)
    out(cyclone_log=lines)
    sys.exit(code)


def fail(why: str) -> None:
    os.write(_STDERR, f"cyclone_peer.py: {why}\n".encode())
    finish(2)


@dataclass
class Empty_(IdlStruct, typename="std_msgs::msg::dds_::Empty_"):
    structure_needs_at_least_one_member: uint8 = 0


@dataclass
class Point_(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class ShortPoint_(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    """A writer whose idea of a Point is one uint32: its samples are 4 bytes where a Point is 24."""
    x: uint32 = 0


@dataclass
class Time_(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class ResponseState_(IdlStruct, typename="radar_msgs::msg::dds_::ResponseState_"):
    stamp: Time_ = field(default_factory=Time_)
    name: str = ""
    state: uint8 = 0
    state_label: str = ""
    start_type: str = ""
    start_policy: str = ""
    last_exit_reason: str = ""
    starts: uint64 = 0
    exits: uint64 = 0
    interrupts: uint64 = 0
    exit_signals: uint64 = 0
    completed: uint64 = 0
    failures: uint64 = 0
    panics: uint64 = 0
    restarts: uint64 = 0
    ignored_starts: uint64 = 0
    ignored_interrupts: uint64 = 0
    ignored_exits: uint64 = 0
    start_queued: bool = False
    malformed: uint64 = 0


# rmw_cyclonedds_cpp's service requests and replies: the rosidl type, with the client's request header
# (`cdds_request_header_t`: the client's id, then the request's sequence number) written in front of the fields
@dataclass
class ConnectRequest_(IdlStruct, typename="radar_msgs::srv::dds_::Connect_Request_"):
    guid: uint64 = 0
    seq: int64 = 0
    kind: uint8 = 0
    source: str = ""
    target: str = ""
    until: str = ""
    timeout: float64 = 0.0
    depth: uint32 = 0
    detach: bool = False


@dataclass
class ConnectResponse_(IdlStruct, typename="radar_msgs::srv::dds_::Connect_Response_"):
    guid: uint64 = 0
    seq: int64 = 0
    ok: bool = False
    error: str = ""
    id: uint64 = 0


@dataclass
class DisconnectRequest_(IdlStruct, typename="radar_msgs::srv::dds_::Disconnect_Request_"):
    guid: uint64 = 0
    seq: int64 = 0
    id: uint64 = 0


@dataclass
class DisconnectResponse_(IdlStruct, typename="radar_msgs::srv::dds_::Disconnect_Response_"):
    guid: uint64 = 0
    seq: int64 = 0
    ok: bool = False
    error: str = ""


def qos(*more: object, transient_local: bool = False, depth: int = 10) -> Qos:
    """rmw_cyclonedds_cpp's QoS for rclcpp's defaults (or a latched topic), in plain CDR as rmw writes it."""
    durability = Policy.Durability.TransientLocal if transient_local else Policy.Durability.Volatile
    return Qos(Policy.Reliability.Reliable(duration(seconds=1)), durability, Policy.History.KeepLast(depth),
               Policy.DataRepresentation(use_cdrv0_representation=True), *more)


def topic(dp: DomainParticipant, ros_name: str, ty: type) -> Topic:
    return Topic(dp, "rt" + ros_name, ty)


def wait(cond, what: str, timeout: float = TIMEOUT) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            fail(f"timed out after {timeout}s waiting for {what}")
        time.sleep(0.005)


def take_one(reader: DataReader, what: str, timeout: float = TIMEOUT):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = reader.take(N=1)
        if got:
            return got[0]
        time.sleep(0.002)
    fail(f"timed out after {timeout}s waiting for {what}")


def drive(dp: DomainParticipant, response: str) -> None:
    """What an rclcpp node on rmw_cyclonedds_cpp does with `ros2 topic pub` and `ros2 topic echo`."""
    signals = {s: DataReader(dp, topic(dp, f"{response}/{s}", Empty_), qos=qos())
               for s in ("started", "interrupted", "exited")}
    start = DataWriter(dp, topic(dp, f"{response}/start", Empty_), qos=qos())
    interrupt = DataWriter(dp, topic(dp, f"{response}/interrupt", Empty_), qos=qos())
    wait(lambda: start.get_matched_subscriptions() and interrupt.get_matched_subscriptions()
         and all(r.get_matched_publications() for r in signals.values()),
         f"{response}'s slots and signals to match")
    start.write(Empty_())
    take_one(signals["started"], f"{response}/started")
    out(signal="started")
    interrupt.write(Empty_())
    take_one(signals["interrupted"], f"{response}/interrupted")
    out(signal="interrupted")
    take_one(signals["exited"], f"{response}/exited")
    out(signal="exited")
    # a late reader of the latched state: the current state only
    state = DataReader(dp, topic(dp, f"{response}/state", ResponseState_), qos=qos(transient_local=True, depth=1))
    s = take_one(state, f"{response}/state")
    out(state=s.state_label, starts=int(s.starts), interrupts=int(s.interrupts), exits=int(s.exits),
        name=s.name, start_type=s.start_type)


def listen(dp: DomainParticipant, event: str, n: int) -> None:
    triggered = DataReader(dp, topic(dp, f"{event}/triggered", Empty_), qos=qos())
    for i in range(n):
        take_one(triggered, f"{event}/triggered #{i + 1}")
        out(triggered=i + 1)


def level(dp: DomainParticipant, name: str) -> None:
    """Three writers of `geometry_msgs/msg/Point` on NAME/triggered, each from a participant of its own: one
    that announces no type hash (plain DDS) but whose idea of a Point is one uint32; one that announces another
    definition's hash; one that announces the hash rosidl wrote into the geometry_msgs wheel (a Jazzy peer).
    The test arms its statement, then says go; the first two write, then the third writes x=1.5."""
    hash_file = Path(sys.prefix) / "share/geometry_msgs/msg/Point.json"
    rihs = json.loads(hash_file.read_text())["type_hashes"][0]["hash_string"]
    other = "RIHS01_" + "ab" * 32
    short_dp, other_dp = DomainParticipant(dp.domain_id), DomainParticipant(dp.domain_id)
    ros_name = f"{name}/triggered"
    short = DataWriter(short_dp, topic(short_dp, ros_name, ShortPoint_), qos=qos())
    good = DataWriter(dp, topic(dp, ros_name, Point_),
                      qos=qos(Policy.Userdata(f"typehash={rihs};".encode())))
    out(up=True, hash=rihs)
    sys.stdin.readline()
    wait(lambda: short.get_matched_subscriptions() and good.get_matched_subscriptions(),
         f"a reader of {ros_name} for both writers")
    short.write(ShortPoint_(x=7))
    # another definition: DDS matches it by name alone, Cyclone included; the reader must refuse it
    wrong = DataWriter(other_dp, topic(other_dp, ros_name, Point_),
                       qos=qos(Policy.Userdata(f"typehash={other};".encode())))
    # (a reader that is gone, because the short sample used its `once` up, is not matched: go on after a while)
    deadline = time.monotonic() + 3.0
    while not wrong.get_matched_subscriptions() and time.monotonic() < deadline:
        time.sleep(0.005)
    matched = bool(wrong.get_matched_subscriptions())
    wrong.write(Point_(x=7.0))
    time.sleep(0.3)
    good.write(Point_(x=1.5))
    out(wrote=["short", "other", "good"], other=other, other_matched_by_cyclone=matched)
    sys.stdin.readline()


def pub_once(dp: DomainParticipant, name: str) -> None:
    """A fresh participant, a writer, a wait for one matched reader, one sample, 0.1 s, gone: `ros2 topic pub
    --once` (its `-w 1` and `--keep-alive 0.1`)."""
    writer = DataWriter(dp, topic(dp, name, Empty_), qos=qos())
    wait(lambda: writer.get_matched_subscriptions(), f"a reader of {name}")
    writer.write(Empty_())
    time.sleep(0.1)
    out(published=True)


class CycloneClient:
    """A service client as rmw_cyclonedds_cpp makes one: `rq/<service>Request` and `rr/<service>Reply`, its id
    in every request's header, and of the replies (every client's) only those whose header is its own."""

    def __init__(self, dp: DomainParticipant, service: str, req: type, resp: type, client_id: int) -> None:
        self.requests = DataWriter(dp, Topic(dp, f"rq{service}Request", req), qos=qos())
        self.replies = DataReader(dp, Topic(dp, f"rr{service}Reply", resp), qos=qos())
        self.client_id, self.seq, self.service = client_id, 0, service
        wait(lambda: self.requests.get_matched_subscriptions() and self.replies.get_matched_publications(),
             f"the {service} service to be available")

    def call(self, request):
        self.seq += 1
        request.guid, request.seq = self.client_id, self.seq
        self.requests.write(request)
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            for reply in self.replies.take(N=10):
                if reply.guid == self.client_id and reply.seq == self.seq:
                    return reply
            time.sleep(0.002)
        fail(f"no reply from {self.service} to request {self.seq} in {TIMEOUT}s")


def manage(dp: DomainParticipant, manager: str, source: str, target: str) -> None:
    """`whenever SOURCE start TARGET` through MANAGER's services from a client on rmw_cyclonedds_cpp: connect, then
    (when the test says) disconnect, then connect again and (when the test says) leave: the connection is the
    caller's and goes with it."""
    connect = CycloneClient(dp, f"{manager}/connect", ConnectRequest_, ConnectResponse_, 0x1122334455667788)
    disconnect = CycloneClient(dp, f"{manager}/disconnect", DisconnectRequest_, DisconnectResponse_,
                               0x0102030405060708)
    request = lambda: ConnectRequest_(kind=1, source=source, target=target)  # noqa: E731 (WHENEVER)
    r = connect.call(request())
    out(connected=bool(r.ok), id=int(r.id), error=r.error, seq=int(r.seq))
    sys.stdin.readline()
    d = disconnect.call(DisconnectRequest_(id=r.id))
    out(disconnected=bool(d.ok), error=d.error)
    unknown = disconnect.call(DisconnectRequest_(id=987654321))
    out(disconnected_unknown=bool(unknown.ok), error=unknown.error)
    sys.stdin.readline()
    r = connect.call(request())
    out(connected=bool(r.ok), id=int(r.id), error=r.error, seq=int(r.seq))
    sys.stdin.readline()


def main() -> None:
    dp = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "drive":
        drive(dp, args[0])
    elif cmd == "listen":
        listen(dp, args[0], int(args[1]))
    elif cmd == "level":
        level(dp, args[0])
    elif cmd == "pub_once":
        pub_once(dp, args[0])
    elif cmd == "manage":
        manage(dp, args[0], args[1], args[2])
    else:
        fail(f"unknown command {cmd}")
    finish()


if __name__ == "__main__":
    main()
