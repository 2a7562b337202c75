"""One sqlite3 storage file (``.db3``), as rosbag2's sqlite3 plugin writes it — read only.

Tables: ``topics`` (name, type, serialization_format, offered_qos_profiles, type_description_hash from
Iron on), ``messages`` (topic_id, timestamp, data) and, from Iron on, ``message_definitions`` with the
``ros2msg`` text of each type. Older files have fewer columns, so rows are read by column name.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path

from nodes.bag.mcap_file import RawMessage, StorageError
from nodes.bag.rosbag2 import TopicInfo


def _connect(path: Path) -> sqlite3.Connection:
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
        db.row_factory = sqlite3.Row
        db.execute("SELECT id, name, type FROM topics LIMIT 1").fetchall()
        db.execute("SELECT topic_id, timestamp, data FROM messages LIMIT 0").fetchall()
        return db
    except sqlite3.Error as exc:
        raise StorageError(f"{path}: not a readable rosbag2 sqlite3 file ({exc})") from None


def _definitions(db: sqlite3.Connection) -> dict[str, str]:
    try:
        rows = db.execute("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions")
        return {r["topic_type"]: r["encoded_message_definition"] for r in rows
                if r["encoding"] == "ros2msg" and r["encoded_message_definition"]}
    except sqlite3.Error:  # Humble and older: no stored definitions, ours are used
        return {}


def summary(path: Path) -> tuple[list[TopicInfo], int, int, int]:
    """(topics, message count, first and last timestamp in ns)."""
    db = _connect(path)
    try:
        topics = []
        for row in db.execute("SELECT t.*, (SELECT COUNT(*) FROM messages m WHERE m.topic_id = t.id) AS n "
                              "FROM topics t ORDER BY t.name"):
            keys = row.keys()
            topics.append(TopicInfo(name=row["name"], type=row["type"], count=row["n"],
                                    serialization_format=row["serialization_format"],
                                    type_hash=row["type_description_hash"] if "type_description_hash" in keys
                                    else ""))
        count, first, last = db.execute("SELECT COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages").fetchone()
        return topics, count, first or 0, last or 0
    except sqlite3.Error as exc:
        raise StorageError(f"{path}: not a readable rosbag2 sqlite3 file ({exc})") from None
    finally:
        db.close()


def messages(path: Path, topics: set[str] | None) -> Iterator[RawMessage]:
    db = _connect(path)
    try:
        definitions = _definitions(db)
        known = {row["id"]: (row["name"], row["type"], row["serialization_format"])
                 for row in db.execute("SELECT * FROM topics")}
        ids = [i for i, (name, _, _) in known.items() if topics is None or name in topics]
        if not ids:
            return
        query = (f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({','.join('?' * len(ids))}) "
                 "ORDER BY timestamp, id")
        for topic_id, timestamp, data in db.execute(query, ids):
            name, type_name, fmt = known[topic_id]
            if fmt != "cdr":
                raise StorageError(f"{path}: topic {name} is encoded as '{fmt}', only cdr is supported")
            yield RawMessage(name, type_name, definitions.get(type_name), timestamp, bytes(data))
    except sqlite3.Error as exc:
        raise StorageError(f"{path}: not a readable rosbag2 sqlite3 file ({exc})") from None
    finally:
        db.close()
