"""A ROS 2 action server over Zenoh written from rmw_zenoh's design document (docs/design.md of ros2/rmw_zenoh),
with the eclipse-zenoh wheel and rclpy's CDR, as `zenoh_service_client.py` is for a service client: nothing here
comes from radar_ros or ros2-client.

    python zenoh_action_server.py ROUTER_ENDPOINT DOMAIN ACTION

Serves `test_msgs/action/Fibonacci` at ACTION as an rclpy action server over rmw_zenoh would: an action is
three services and two topics under `<ACTION>/_action/` (rcl_action's names), each named as the design names
entities, with the RIHS01 hashes rosidl wrote into this venv's `share/` JSON files:

- `send_goal` (`test_msgs::action::dds_::Fibonacci_SendGoal_`), `get_result` (`..._GetResult_`): queryables on
  `<domain>/<action>/_action/<service>/<type>/<hash>` with their `SS` tokens; `cancel_goal`
  (`action_msgs::srv::dds_::CancelGoal_`) likewise;
- `feedback` (`test_msgs::action::dds_::Fibonacci_FeedbackMessage_`) and `status`
  (`action_msgs::msg::dds_::GoalStatusArray_`): publishers with their `MP` tokens, each sample with the
  attachment (sequence number, time, the publisher's GID).

A reply carries the request's attachment back (its sequence number and the client's GID, a new time), as
rmw_zenoh's server does. The server, one goal at a time as the test needs it:

- a goal of order < 0 is rejected; another is accepted (status EXECUTING), then one feedback message every
  0.1 s, each one Fibonacci number longer ([0, 1], [0, 1, 1], ...), until the sequence has `order` numbers:
  SUCCEEDED (status 4) with it;
- a cancel naming the running goal is answered ERROR_NONE with that goal, and the goal ends CANCELED (status 5)
  with the sequence so far; one naming another goal is answered ERROR_UNKNOWN_GOAL_ID;
- a result request is answered when its goal has ended (held until then).

Prints {"up": <session id>} once its entities are declared, then one JSON line per thing that happens:
{"goal": order, "accepted": bool}, {"feedback": n}, {"cancel": true, "known": bool}, {"result_asked": true},
{"ended": status}, {"answered_result": status}, {"bad_attachment": hex}. Ends when stdin closes.
"""

import importlib
import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, Optional

import zenoh
from rclpy.serialization import deserialize_message, serialize_message

from zenoh_peer import mangle, out, session_config

# rosidl's generated classes have no type stubs: taken as `Any`
_msgs: Any = importlib.import_module("action_msgs.msg")
GoalInfo: Any = _msgs.GoalInfo
GoalStatus: Any = _msgs.GoalStatus
GoalStatusArray: Any = _msgs.GoalStatusArray
CancelGoal: Any = importlib.import_module("action_msgs.srv").CancelGoal
Fibonacci: Any = importlib.import_module("test_msgs.action").Fibonacci
NODE = "zenoh_action_server"
# the design document's default QoS of services and of these topics: reliable, volatile, keep last 10
QOS = "::,10:,:,:,,"


def rosidl_hash(pkg: str, kind: str, file: str, type_name: str) -> str:
    """The hash rosidl wrote for `type_name` in `share/<pkg>/<kind>/<file>.json`."""
    doc = json.loads((Path(sys.prefix) / "share" / pkg / kind / f"{file}.json").read_text())
    for h in doc["type_hashes"]:
        if h["type_name"] == type_name:
            return str(h["hash_string"])
    raise SystemExit(f"no hash for {type_name} in {pkg}/{kind}/{file}.json")


def attachment(seq: int, gid: bytes) -> bytes:
    """rmw_zenoh's attachment: sequence number, nanoseconds since the epoch (both i64 little-endian), the GID
    with its length before it."""
    return (
        seq.to_bytes(8, "little", signed=True)
        + time.time_ns().to_bytes(8, "little", signed=True)
        + bytes([len(gid)])
        + gid
    )


def fibonacci(n: int) -> list[int]:
    seq = [0, 1]
    while len(seq) < n:
        seq.append(seq[-1] + seq[-2])
    return seq[: max(n, 2)]


class Goal:
    """The running (or last) goal: its id, order, sequence so far and end."""

    def __init__(self, goal_id: bytes, order: int) -> None:
        self.id = goal_id
        self.order = order
        self.sequence = [0, 1]
        self.status: Optional[int] = None
        self.ended = threading.Event()


class Server:
    def __init__(self, session: zenoh.Session, domain: str, action: str) -> None:
        self.session = session
        self.domain = domain
        self.action = action.rstrip("/")
        self.zid = str(session.info.zid())
        self.gid = os.urandom(16)
        self.lock = threading.Lock()
        self.goal: Optional[Goal] = None
        self.seq = 0
        self.live: list[Any] = [
            session.liveliness().declare_token(f"@ros2_lv/{domain}/{self.zid}/0/0/NN/%/%/{NODE}")
        ]
        self.entities = 0
        self.queryables: list[Any] = []
        goal_t = "test_msgs::action::dds_::Fibonacci_SendGoal_"
        result_t = "test_msgs::action::dds_::Fibonacci_GetResult_"
        cancel_t = "action_msgs::srv::dds_::CancelGoal_"
        self.serve("send_goal", goal_t, rosidl_hash("test_msgs", "action", "Fibonacci", "test_msgs/action/Fibonacci_SendGoal"), self.on_goal)
        self.serve("get_result", result_t, rosidl_hash("test_msgs", "action", "Fibonacci", "test_msgs/action/Fibonacci_GetResult"), self.on_result)
        self.serve("cancel_goal", cancel_t, rosidl_hash("action_msgs", "srv", "CancelGoal", "action_msgs/srv/CancelGoal"), self.on_cancel)
        self.feedback = self.publisher(
            "feedback",
            "test_msgs::action::dds_::Fibonacci_FeedbackMessage_",
            rosidl_hash("test_msgs", "action", "Fibonacci", "test_msgs/action/Fibonacci_FeedbackMessage"),
        )
        self.status = self.publisher(
            "status",
            "action_msgs::msg::dds_::GoalStatusArray_",
            rosidl_hash("action_msgs", "msg", "GoalStatusArray", "action_msgs/msg/GoalStatusArray"),
        )

    def entity(self, kind: str, name: str, dds_type: str, type_hash: str) -> str:
        """Declares the liveliness token of entity `kind` on `name`; its key expression."""
        self.entities += 1
        tail = f"/{mangle(name)}/{dds_type}/{type_hash}/{QOS}"
        self.live.append(
            self.session.liveliness().declare_token(
                f"@ros2_lv/{self.domain}/{self.zid}/0/{self.entities}/{kind}/%/%/{NODE}{tail}"
            )
        )
        return f"{self.domain}/{name.strip('/')}/{dds_type}/{type_hash}"

    def serve(self, service: str, dds_type: str, type_hash: str, handler: Any) -> None:
        key = self.entity("SS", f"{self.action}/_action/{service}", dds_type, type_hash)
        self.queryables.append(self.session.declare_queryable(key, handler, complete=True))

    def publisher(self, topic: str, dds_type: str, type_hash: str) -> tuple[Any, str]:
        key = self.entity("MP", f"{self.action}/_action/{topic}", dds_type, type_hash)
        return (self.session.declare_publisher(key), key)

    def put(self, pub: tuple[Any, str], msg: Any) -> None:
        with self.lock:
            self.seq += 1
            seq = self.seq
        pub[0].put(serialize_message(msg), attachment=attachment(seq, self.gid))

    @staticmethod
    def request(query: zenoh.Query, cls: Any) -> Optional[tuple[Any, bytes]]:
        """The request and the attachment to answer with (its sequence number, the client's GID)."""
        att = query.attachment.to_bytes() if query.attachment is not None else b""
        if len(att) < 17 or len(att) < 17 + att[16]:
            out({"bad_attachment": att.hex()})
            return None
        payload = query.payload.to_bytes() if query.payload is not None else b""
        seq = int.from_bytes(att[0:8], "little", signed=True)
        return deserialize_message(payload, cls), attachment(seq, att[17 : 17 + att[16]])

    @staticmethod
    def reply(query: zenoh.Query, msg: Any, att: bytes) -> None:
        query.reply(query.key_expr, serialize_message(msg), attachment=att)

    def publish_status(self, goal: Goal, status: int) -> None:
        s = GoalStatus()
        s.goal_info.goal_id.uuid = list(goal.id)
        s.status = status
        arr = GoalStatusArray()
        arr.status_list = [s]
        self.put(self.status, arr)

    def on_goal(self, query: zenoh.Query) -> None:
        got = self.request(query, Fibonacci.Impl.SendGoalService.Request)
        if got is None:
            return
        req, att = got
        accepted = req.goal.order >= 0
        out({"goal": req.goal.order, "accepted": accepted})
        resp = Fibonacci.Impl.SendGoalService.Response()
        resp.accepted = accepted
        resp.stamp.sec = int(time.time())
        if not accepted:
            self.reply(query, resp, att)
            return
        goal = Goal(bytes(req.goal_id.uuid), req.goal.order)
        with self.lock:
            self.goal = goal
        self.reply(query, resp, att)
        self.publish_status(goal, GoalStatus.STATUS_EXECUTING)
        threading.Thread(target=self.execute, args=(goal,), daemon=True).start()

    def execute(self, goal: Goal) -> None:
        while len(goal.sequence) < goal.order:
            time.sleep(0.1)
            with self.lock:
                if goal.status is not None:
                    return
                goal.sequence.append(goal.sequence[-1] + goal.sequence[-2])
                n = len(goal.sequence)
            fb = Fibonacci.Impl.FeedbackMessage()
            fb.goal_id.uuid = list(goal.id)
            fb.feedback.sequence = list(goal.sequence)
            self.put(self.feedback, fb)
            out({"feedback": n})
        self.end(goal, GoalStatus.STATUS_SUCCEEDED)

    def end(self, goal: Goal, status: int) -> None:
        with self.lock:
            if goal.status is not None:
                return
            goal.status = status
        self.publish_status(goal, status)
        out({"ended": status})
        goal.ended.set()

    def on_cancel(self, query: zenoh.Query) -> None:
        got = self.request(query, CancelGoal.Request)
        if got is None:
            return
        req, att = got
        with self.lock:
            goal = self.goal
        known = goal is not None and goal.status is None and bytes(req.goal_info.goal_id.uuid) == goal.id
        out({"cancel": True, "known": known})
        resp = CancelGoal.Response()
        if known and goal is not None:
            info = GoalInfo()
            info.goal_id.uuid = list(goal.id)
            resp.return_code = CancelGoal.Response.ERROR_NONE
            resp.goals_canceling = [info]
            self.reply(query, resp, att)
            self.end(goal, GoalStatus.STATUS_CANCELED)
        else:
            resp.return_code = CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID
            self.reply(query, resp, att)

    def on_result(self, query: zenoh.Query) -> None:
        got = self.request(query, Fibonacci.Impl.GetResultService.Request)
        if got is None:
            return
        req, att = got
        out({"result_asked": True})
        with self.lock:
            goal = self.goal if self.goal is not None and bytes(req.goal_id.uuid) == self.goal.id else None

        def answer() -> None:
            resp = Fibonacci.Impl.GetResultService.Response()
            if goal is None:
                resp.status = GoalStatus.STATUS_UNKNOWN
            else:
                goal.ended.wait(60.0)
                resp.status = goal.status if goal.status is not None else GoalStatus.STATUS_UNKNOWN
                resp.result.sequence = list(goal.sequence)
            self.reply(query, resp, att)
            out({"answered_result": resp.status})

        # the query is answered later, from a thread of its own: the callback returns at once
        threading.Thread(target=answer, daemon=True).start()


def main() -> None:
    router, domain, action = sys.argv[1:4]
    with zenoh.open(session_config(router)) as session:
        server = Server(session, domain, action)
        out({"up": server.zid})
        for _ in sys.stdin:
            pass
        del server


if __name__ == "__main__":
    main()
