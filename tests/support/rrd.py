"""Read a saved ``.rrd`` back with Rerun's own reader (``rerun.chunk.RrdReader``), for tests and the bench.

Rerun 0.41 has no ``rerun.dataframe`` module: its recording API is ``RrdReader(path).stream().collect()``
(a ``ChunkStore``; ``ChunkStore.reader()`` needs the optional ``datafusion`` package, so we read the
chunks' Arrow record batches directly). ``python -m tests.support.rrd FILE.rrd`` prints a summary.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa
from rerun.chunk import RrdReader

SIM = "sim_time"
WALL_TIMELINES = ("log_time", "wall_time")  # epoch timestamps, kept as seconds


@dataclass
class EntityData:
    """Rows of one entity: ``static`` components, and temporal rows sorted by sim time."""

    static: dict[str, Any] = field(default_factory=dict)
    rows: list[dict[str, Any]] = field(default_factory=list)

    def column(self, name: str) -> list[tuple[float, Any]]:
        """``(sim_time_s, value)`` for every row that has component ``name`` (e.g. ``Scalars:scalars``)."""
        return [(row[SIM], row[name]) for row in self.rows if row.get(name) is not None and SIM in row]


def _as_seconds(array: pa.Array) -> list[float | None]:
    return [None if v is None else v / 1e9 for v in array.cast(pa.int64()).to_pylist()]


def load(path: str | Path) -> dict[str, EntityData]:
    """Every entity of the first recording in ``path`` (entity paths without the leading ``/``)."""
    store = RrdReader(str(path)).stream().collect()
    entities: dict[str, EntityData] = defaultdict(EntityData)
    for chunk in store.stream():
        entity = entities[chunk.entity_path.lstrip("/")]
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if ":" in n]
        if chunk.is_static:
            for name in names:
                values = batch.column(name).to_pylist()
                if values:
                    entity.static[name] = values[-1]
            continue
        timelines = {t: _as_seconds(batch.column(t)) for t in (SIM, *WALL_TIMELINES) if t in batch.schema.names}
        columns = {name: batch.column(name).to_pylist() for name in names}
        for i in range(batch.num_rows):
            row: dict[str, Any] = {name: values[i] for name, values in columns.items()}
            row.update({t: values[i] for t, values in timelines.items() if values[i] is not None})
            entity.rows.append(row)
    for entity in entities.values():
        entity.rows.sort(key=lambda r: r.get(SIM, -1.0))
    return dict(entities)


def record(path: Path, body: Callable[[Any], None], application: str = "zenroid_test") -> dict[str, EntityData]:
    """What ``body(recording)`` logs, through a real Rerun recording saved to ``path`` and read back."""
    import rerun as rr  # noqa: PLC0415 - only the tests that record pay for it

    recording = rr.RecordingStream(application)
    recording.save(str(path))
    body(recording)
    recording.flush()
    recording.disconnect()
    return load(path)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) != 1:
        print("usage: python -m tests.support.rrd FILE.rrd", file=sys.stderr)
        return 2
    for name, data in sorted(load(argv[0]).items()):
        print(f"{name}: {len(data.rows)} rows, static {sorted(data.static)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
