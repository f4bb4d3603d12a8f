#!/usr/bin/env python3
"""Reads an MCAP file with the independent Python readers (`mcap`, `mcap-ros2-support`) and prints one JSON
line per message: topic, schema name and encoding, message encoding, log and publish time, and the message
decoded from its CDR with the schema stored in the file (as Foxglove and rosbag2 tooling would); a JSON message
(radar record's /radar/trace) as its JSON.

    mcap_read.py FILE.mcap             a message the reader cannot decode (it implements no wstring) is printed
                                       with "undecodable": the reader's reason, instead of "msg"
    mcap_read.py --summary FILE.mcap   one JSON line: whether the file has a summary, and its statistics
"""
import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def plain(v: object) -> object:
    """A decoded ROS message (dynamic class) as plain JSON values."""
    if hasattr(v, "__slots__"):
        return {k: plain(getattr(v, k)) for k in v.__slots__ if not k.startswith("_")}
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, bytes):
        return list(v)
    return v


def summary(path: str) -> None:
    with open(path, "rb") as f:
        s = make_reader(f).get_summary()
        stats = s.statistics if s is not None else None
        print(json.dumps({
            "summary": s is not None,
            "messages": stats.message_count if stats else None,
            "chunks": len(s.chunk_indexes) if s is not None else None,
        }), flush=True)


def main() -> None:
    if sys.argv[1] == "--summary":
        summary(sys.argv[2])
        return
    factory = DecoderFactory()
    decoders: dict = {}
    with open(sys.argv[1], "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            line = {
                "topic": channel.topic,
                "schema": schema.name,
                "schema_encoding": schema.encoding,
                "message_encoding": channel.message_encoding,
                "log_time": message.log_time,
                "publish_time": message.publish_time,
            }
            if channel.message_encoding == "json":  # radar record's /radar/trace
                line["msg"] = json.loads(message.data)
                print(json.dumps(line), flush=True)
                continue
            if schema.id not in decoders:
                decoders[schema.id] = factory.decoder_for(channel.message_encoding, schema)
            try:
                line["msg"] = plain(decoders[schema.id](message.data))
            except NotImplementedError as e:  # the reader's own limits (it reads no wstring): said, not hidden
                line["undecodable"] = str(e)
            print(json.dumps(line), flush=True)


if __name__ == "__main__":
    main()
