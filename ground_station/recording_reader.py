"""Read a recording back with Rerun's own API (`rerun.chunk.RrdReader`): per entity, its
static components and its rows on the ``sim_time`` timeline. Used by the tests to check a
recording against a mission report, and handy for scripts that post-process a replay.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa
from rerun.chunk import RrdReader

from ground_station.rerun_log import TIMELINE

_NOT_DATA = {"rerun.controls.RowId"}


@dataclass
class EntityRows:
    static: dict[str, Any] = field(default_factory=dict)  # component -> value
    rows: list[tuple[float, dict[str, Any]]] = field(default_factory=list)  # (sim_time s, ...)

    def sorted_rows(self) -> list[tuple[float, dict[str, Any]]]:
        return sorted(self.rows, key=lambda r: r[0])

    def series(self, component: str) -> list[tuple[float, Any]]:
        """``(t_s, value)`` of every row that sets ``component``, in time order."""
        return [(t, row[component]) for t, row in self.sorted_rows()
                if row.get(component) is not None]

    def line(self, name: str) -> list[tuple[float, float]]:
        """``(t_s, value)`` of one line of a plot entity (a line per name in its static
        ``SeriesLines:names``), in time order; rows before the line existed, or where it had
        no value yet (NaN), are skipped."""
        names = self.static.get("SeriesLines:names") or []
        if name not in names:
            raise KeyError(f"no line {name!r} among {names}")
        i = names.index(name)
        out = []
        for t, values in self.series("Scalars:scalars"):
            if i < len(values) and values[i] == values[i]:  # NaN != NaN
                out.append((t, values[i]))
        return out

    def latest(self, component: str) -> Any:
        """The value at the end of the recording (static wins, as in the viewer); a Clear
        logged after the last value makes it None."""
        if component in self.static:
            return self.static[component]
        value = None
        for _, row in self.sorted_rows():
            if row.get(component) is not None:
                value = row[component]
            elif row.get("Clear:is_recursive") is not None:
                value = None
        return value


def read_recording(path: str | Path, timeline: str = TIMELINE) -> dict[str, EntityRows]:
    """Entity path (``/map/spots``) -> its data, from the first recording in ``path``; rows
    are indexed by ``timeline`` (durations in seconds, sequences as numbers)."""
    entities: dict[str, EntityRows] = {}
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        entity = entities.setdefault(chunk.entity_path, EntityRows())
        names = [n for n in batch.schema.names
                 if n not in _NOT_DATA and _is_data(batch.schema.field(n).metadata)]
        columns = {n: batch.column(n).to_pylist() for n in names}
        if chunk.is_static:
            for n in names:
                if columns[n] and columns[n][-1] is not None:
                    entity.static[n] = columns[n][-1]
            continue
        if timeline not in batch.schema.names:
            continue
        index = batch.column(timeline)
        scale = 1e-9 if pa.types.is_duration(index.type) else 1.0
        for i, t in enumerate(index.cast(pa.int64()).to_pylist()):
            if t is not None:  # a row without a time on this timeline is not on it
                entity.rows.append((t * scale, {n: columns[n][i] for n in names}))
    return entities


def _is_data(metadata: dict[bytes, bytes] | None) -> bool:
    """A column of logged data (not Rerun's row ids or times)."""
    return metadata is not None and metadata.get(b"rerun:kind") == b"data"

