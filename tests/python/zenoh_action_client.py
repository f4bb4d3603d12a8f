"""A ROS 2 action client over Zenoh written from rmw_zenoh's design document (docs/design.md of ros2/rmw_zenoh),
with the eclipse-zenoh wheel and rclpy's CDR, as `zenoh_action_server.py` is the server: nothing here comes from
radar_ros or ros2-client.

    python zenoh_action_client.py ROUTER_ENDPOINT DOMAIN ACTION ORDER [cancel]
    python zenoh_action_client.py ROUTER_ENDPOINT DOMAIN ACTION watch

Sends one `test_msgs/action/Fibonacci` goal of ORDER to the server at ACTION as an rclpy action client over
rmw_zenoh would: under `<ACTION>/_action/`, clients of `send_goal`, `get_result` and `cancel_goal` (queries on
`<domain>/<name>/<type>/<hash>` with the attachment: sequence number, time, the client's GID; `SC` tokens) and
subscriptions to `feedback` and `status` (`MS` tokens), each named with the RIHS01 hash rosidl wrote into this
venv's `share/` JSON files. The `status` subscription is rcl_action's: reliable, transient local, keep last 1,
so as rmw_zenoh makes such a subscription since its 0.2.2, a zenoh-ext advanced subscriber that asks the
publishers' caches (late ones too) for the last sample, its token's QoS saying transient local.

- Waits (10 s at most) for the server's `SS` token of `send_goal` with that type and hash: {"server": key}.
- Sends the goal with a random goal id: {"goal_id": hex}, then {"accepted": bool}. Rejected: ends.
- Accepted: asks for the result at once (as rclpy's client does) and prints {"result": sequence,
  "status": code} when it comes; each feedback message of its goal: {"feedback": length of the sequence};
  each status array naming its goal: {"status": code}.
- With `cancel`, when a line comes on stdin it asks to cancel the goal: {"cancel_answer": return code,
  "canceling": how many goals}.
- {"error": text} when something does not come; ends after the result.

With `watch` instead of an order it sends nothing: it subscribes to `status` only, as a late observer
(`ros2 action info`'s peer, a monitoring node) would, prints the first status array it reads as
{"statuses": [[goal id hex, code], ...]} and ends ({"error": ...} when none comes in 10 s).
"""

import importlib
import os
import queue
import sys
import threading
from typing import Any, Optional

import zenoh
from rclpy.serialization import deserialize_message, serialize_message

from zenoh_action_server import attachment, rosidl_hash
from zenoh_peer import QOS as QOS_OF
from zenoh_peer import latched_subscriber, mangle, out, session_config

# rosidl's generated classes have no type stubs: taken as `Any`
GoalStatusArray: Any = importlib.import_module("action_msgs.msg").GoalStatusArray
CancelGoal: Any = importlib.import_module("action_msgs.srv").CancelGoal
Fibonacci: Any = importlib.import_module("test_msgs.action").Fibonacci
NODE = "zenoh_action_client"
QOS = QOS_OF["volatile"]
# rcl_action's status QoS (rcl_action_qos_profile_status_default): reliable, transient local, keep last 1
STATUS_QOS = QOS_OF["transient_local"]


class Client:
    def __init__(self, session: zenoh.Session, domain: str, action: str) -> None:
        self.session = session
        self.domain = domain
        self.action = action.rstrip("/")
        self.zid = str(session.info.zid())
        self.gid = os.urandom(16)
        self.seq = 0
        self.lock = threading.Lock()
        self.entities = 0
        self.live: list[Any] = [
            session.liveliness().declare_token(f"@ros2_lv/{domain}/{self.zid}/0/0/NN/%/%/{NODE}")
        ]
        fib = ("test_msgs", "action", "Fibonacci")
        self.goal_key = self.entity(
            "SC", "send_goal", "test_msgs::action::dds_::Fibonacci_SendGoal_",
            rosidl_hash(*fib, "test_msgs/action/Fibonacci_SendGoal"),
        )
        self.result_key = self.entity(
            "SC", "get_result", "test_msgs::action::dds_::Fibonacci_GetResult_",
            rosidl_hash(*fib, "test_msgs/action/Fibonacci_GetResult"),
        )
        self.cancel_key = self.entity(
            "SC", "cancel_goal", "action_msgs::srv::dds_::CancelGoal_",
            rosidl_hash("action_msgs", "srv", "CancelGoal", "action_msgs/srv/CancelGoal"),
        )
        self.feedback_key = self.entity(
            "MS", "feedback", "test_msgs::action::dds_::Fibonacci_FeedbackMessage_",
            rosidl_hash(*fib, "test_msgs/action/Fibonacci_FeedbackMessage"),
        )
        self.status_key = self.entity(
            "MS", "status", "action_msgs::msg::dds_::GoalStatusArray_",
            rosidl_hash("action_msgs", "msg", "GoalStatusArray", "action_msgs/msg/GoalStatusArray"),
            STATUS_QOS,
        )

    def entity(self, kind: str, part: str, dds_type: str, type_hash: str, qos: str = QOS) -> str:
        """Declares the token of entity `kind` on `<action>/_action/<part>`; its key expression."""
        self.entities += 1
        name = f"{self.action}/_action/{part}"
        tail = f"/{mangle(name)}/{dds_type}/{type_hash}/{qos}"
        self.live.append(
            self.session.liveliness().declare_token(
                f"@ros2_lv/{self.domain}/{self.zid}/0/{self.entities}/{kind}/%/%/{NODE}{tail}"
            )
        )
        return f"{self.domain}/{name.strip('/')}/{dds_type}/{type_hash}"

    def status_subscriber(self, on_status: Any) -> Any:
        """The `status` subscription as rmw_zenoh makes a transient-local, keep-last-1 one."""
        return latched_subscriber(self.session, self.status_key, on_status)

    def call(self, key: str, request: Any, response_class: Any, timeout: float) -> Optional[Any]:
        """A query as rmw_zenoh's client sends one; the first reply, read as rclpy reads it."""
        with self.lock:
            self.seq += 1
            seq = self.seq
        replies = self.session.get(
            key,
            payload=serialize_message(request),
            attachment=attachment(seq, self.gid),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            consolidation=zenoh.ConsolidationMode.NONE,
            timeout=timeout,
        )
        for reply in replies:
            if reply.ok is not None:
                return deserialize_message(reply.ok.payload.to_bytes(), response_class)
        return None


def wait_server(session: zenoh.Session, domain: str, key_tail: str) -> bool:
    found = threading.Event()

    def on_token(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if sample.kind == zenoh.SampleKind.PUT and "/SS/" in key and key_tail in key and not found.is_set():
            out({"server": key})
            found.set()

    sub = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token, history=True)
    ok = found.wait(10.0)
    del sub
    return ok


def run(session: zenoh.Session, domain: str, action: str, order: int, cancel_on_stdin: bool) -> None:
    c = Client(session, domain, action)
    goal_type = "test_msgs::action::dds_::Fibonacci_SendGoal_"
    if not wait_server(session, domain, f"/{mangle(action.rstrip('/') + '/_action/send_goal')}/{goal_type}/"):
        out({"error": f"no send_goal server of {action} in 10 s"})
        sys.exit(1)
    goal_id = list(os.urandom(16))

    def cancel() -> None:
        req = CancelGoal.Request()
        req.goal_info.goal_id.uuid = goal_id
        answer = c.call(c.cancel_key, req, CancelGoal.Response, 10.0)
        if answer is None:
            out({"error": "no answer to the cancel"})
            return
        out({"cancel_answer": int(answer.return_code), "canceling": len(answer.goals_canceling)})

    def cancel_on_line() -> None:
        if sys.stdin.readline():
            cancel()

    def on_feedback(sample: zenoh.Sample) -> None:
        msg = deserialize_message(sample.payload.to_bytes(), Fibonacci.Impl.FeedbackMessage)
        if list(msg.goal_id.uuid) == goal_id:
            out({"feedback": len(msg.feedback.sequence)})

    def on_status(sample: zenoh.Sample) -> None:
        msg = deserialize_message(sample.payload.to_bytes(), GoalStatusArray)
        for s in msg.status_list:
            if list(s.goal_info.goal_id.uuid) == goal_id:
                out({"status": int(s.status)})

    subs = [
        session.declare_subscriber(c.feedback_key, on_feedback),
        c.status_subscriber(on_status),
    ]
    req = Fibonacci.Impl.SendGoalService.Request()
    req.goal_id.uuid = goal_id
    out({"goal_id": bytes(goal_id).hex()})
    req.goal.order = order
    answer = c.call(c.goal_key, req, Fibonacci.Impl.SendGoalService.Response, 10.0)
    if answer is None:
        out({"error": "no answer to the goal"})
        sys.exit(1)
    out({"accepted": bool(answer.accepted)})
    if not answer.accepted:
        return
    if cancel_on_stdin:
        threading.Thread(target=cancel_on_line, daemon=True).start()
    result_req = Fibonacci.Impl.GetResultService.Request()
    result_req.goal_id.uuid = goal_id
    result = c.call(c.result_key, result_req, Fibonacci.Impl.GetResultService.Response, 60.0)
    if result is None:
        out({"error": "no result"})
        sys.exit(1)
    out({"result": list(result.result.sequence), "status": int(result.status)})
    del subs


def watch(session: zenoh.Session, domain: str, action: str) -> None:
    c = Client(session, domain, action)
    arrays: "queue.Queue[list[list[Any]]]" = queue.Queue()

    def on_status(sample: zenoh.Sample) -> None:
        msg = deserialize_message(sample.payload.to_bytes(), GoalStatusArray)
        arrays.put([[bytes(s.goal_info.goal_id.uuid).hex(), int(s.status)] for s in msg.status_list])

    sub = c.status_subscriber(on_status)
    try:
        out({"statuses": arrays.get(timeout=10.0)})
    except queue.Empty:
        out({"error": f"no status array of {action} in 10 s"})
        sys.exit(1)
    del sub


def main() -> None:
    router, domain, action, order = sys.argv[1:5]
    cancel_on_stdin = sys.argv[5:6] == ["cancel"]
    with zenoh.open(session_config(router)) as session:
        if order == "watch":
            watch(session, domain, action)
        else:
            run(session, domain, action, int(order), cancel_on_stdin)


if __name__ == "__main__":
    main()
