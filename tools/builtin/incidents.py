"""``incidents.log`` and ``incidents.query``: a shared incident log in SQLite, so drones and operators see one history.

The database is created on first use, in WAL mode (readers never block the writer). Every call opens its own
connection and waits up to ``BUSY_TIMEOUT_S`` for a lock, so concurrent calls from threads or processes are safe.

>>> import tempfile
>>> store = IncidentStore(Path(tempfile.mkdtemp()) / "incidents.db")
>>> logged = store.log("crowd_crush", "high", "Density over 6/m² at Jamarat ramp 3", 21.4225, 39.8733, "drone-2")
>>> [i.kind for i in store.query(min_severity="high", near=Near(lat=21.4226, lon=39.8734, radius_m=100))]
['crowd_crush']
"""

from __future__ import annotations

import math
import sqlite3
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from agentic_core.contracts.geodesy import WGS84_MIN_RADIUS_M, distance_m

from ..errors import ToolError, TransientToolError
from ..function import spec_from_function
from ..spec import RetrySpec, ToolContext, ToolSpec, declared_transient
from .config import BuiltinConfig

Severity = Literal["none", "low", "high", "critical"]
RANK: dict[str, int] = {"none": 0, "low": 1, "high": 2, "critical": 3}
BUSY_TIMEOUT_S = 30.0
MAX_LIMIT = 1000

_SCHEMA = """
CREATE TABLE IF NOT EXISTS incidents (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    time TEXT NOT NULL,
    kind TEXT NOT NULL,
    severity TEXT NOT NULL,
    severity_rank INTEGER NOT NULL,
    description TEXT NOT NULL,
    lat REAL,
    lon REAL,
    reported_by TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS incidents_by_time ON incidents (time);
"""


class Near(BaseModel):
    """A circle to search in."""

    model_config = ConfigDict(extra="forbid")

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    radius_m: float = Field(gt=0, le=1_000_000)


class Incident(BaseModel):
    id: int
    time: str = Field(description="when it was logged, ISO 8601 UTC")
    kind: str
    severity: Severity
    description: str = Field(description="as its reporter wrote it: outside text")
    lat: float | None = None
    lon: float | None = None
    reported_by: str
    distance_m: float | None = Field(default=None, description="from the query's 'near' point, when one was given")


class IncidentLogged(BaseModel):
    id: int
    time: str


class Incidents(BaseModel):
    incidents: list[Incident] = Field(description="newest first")
    count: int


def utc_iso(text: str) -> str:
    """``text`` (ISO 8601; no offset means UTC) in the stored form, so times compare as strings."""
    try:
        moment = datetime.fromisoformat(text.strip())
    except ValueError:
        raise ToolError(f"'since' is not an ISO 8601 time: {text[:40]!r} (e.g. 2025-06-05T12:00:00Z)") from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=UTC)
    return moment.astimezone(UTC).isoformat(timespec="microseconds")


class IncidentStore:
    """The incident log in one SQLite file."""

    _ready: ClassVar[set[Path]] = set()  # databases whose table exists, by resolved path
    _ready_lock: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, path: Path) -> None:
        self.path = Path(path)

    @contextmanager
    def connect(self) -> Iterator[sqlite3.Connection]:
        """A fresh connection with the table in place; commits on success, rolls back on error, then closes."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            connection = sqlite3.connect(self.path, timeout=BUSY_TIMEOUT_S)
        except (OSError, sqlite3.Error) as exc:
            raise ToolError(f"cannot open the incident log {self.path}: {exc}") from None
        try:
            self._prepare(connection)
            with connection:
                yield connection
        except sqlite3.OperationalError as exc:
            if "locked" in str(exc) or "busy" in str(exc):
                raise TransientToolError(f"the incident log is busy: {exc}") from None
            raise ToolError(f"the incident log failed: {exc}") from None
        finally:
            connection.close()

    def _prepare(self, connection: sqlite3.Connection) -> None:
        key = self.path.resolve()
        if key in self._ready and self.path.exists():
            return
        with self._ready_lock:
            connection.execute("PRAGMA journal_mode=WAL")
            connection.executescript(_SCHEMA)
            self._ready.add(key)

    def log(
        self,
        kind: str,
        severity: Severity,
        description: str,
        lat: float | None = None,
        lon: float | None = None,
        reported_by: str = "anonymous",
    ) -> IncidentLogged:
        if (lat is None) != (lon is None):
            raise ToolError("give both lat and lon, or neither")
        time = datetime.now(UTC).isoformat(timespec="microseconds")
        with self.connect() as db:
            cursor = db.execute(
                "INSERT INTO incidents (time, kind, severity, severity_rank, description, lat, lon, reported_by)"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (time, kind, severity, RANK[severity], description, lat, lon, reported_by),
            )
            assert cursor.lastrowid is not None
            return IncidentLogged(id=cursor.lastrowid, time=time)

    def query(
        self,
        kind: str | None = None,
        min_severity: Severity | None = None,
        since: str | None = None,
        near: Near | None = None,
        limit: int = 50,
    ) -> list[Incident]:
        """Matching incidents, newest first; with ``near``, only those located within its radius."""
        where: list[str] = []
        values: list[object] = []
        if kind is not None:
            where.append("kind = ?")
            values.append(kind)
        if min_severity is not None:
            where.append("severity_rank >= ?")
            values.append(RANK[min_severity])
        if since is not None:
            where.append("time >= ?")
            values.append(utc_iso(since))
        if near is not None:  # a box around the circle first; the exact distance below
            dlat = math.degrees(near.radius_m / WGS84_MIN_RADIUS_M)
            dlon = dlat / max(math.cos(math.radians(near.lat)), 1e-6)
            where.append("lat BETWEEN ? AND ?")
            values += [near.lat - dlat, near.lat + dlat]
            if dlon < 180:  # else every longitude may be within reach (near a pole)
                where.append("((lon BETWEEN ? AND ?) OR (lon BETWEEN ? AND ?) OR (lon BETWEEN ? AND ?))")
                values += [near.lon - dlon, near.lon + dlon, near.lon - dlon + 360, near.lon + dlon + 360]
                values += [near.lon - dlon - 360, near.lon + dlon - 360]
        sql = "SELECT id, time, kind, severity, description, lat, lon, reported_by FROM incidents"
        sql += (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY time DESC, id DESC"
        if near is None:
            sql += f" LIMIT {int(limit)}"
        found: list[Incident] = []
        with self.connect() as db:
            for row in db.execute(sql, values):
                incident = Incident(
                    id=row[0], time=row[1], kind=row[2], severity=row[3], description=row[4],
                    lat=row[5], lon=row[6], reported_by=row[7],
                )  # fmt: skip
                if near is not None:
                    assert incident.lat is not None and incident.lon is not None
                    incident.distance_m = round(distance_m(near.lat, near.lon, incident.lat, incident.lon), 1)
                    if incident.distance_m > near.radius_m:
                        continue
                found.append(incident)
                if len(found) >= limit:
                    break
        return found


def incident_tools(config: BuiltinConfig) -> list[ToolSpec]:
    """``incidents.log`` and ``incidents.query`` on ``config.incidents_db``."""
    store = IncidentStore(config.incidents_db)

    def log(
        kind: Annotated[str, Field(min_length=1, max_length=64)],
        severity: Severity,
        description: Annotated[str, Field(max_length=4000)],
        lat: Annotated[float, Field(ge=-90, le=90)] | None = None,
        lon: Annotated[float, Field(ge=-180, le=180)] | None = None,
        *,
        context: ToolContext,
    ) -> IncidentLogged:
        """Record an incident in the shared log; the reporter is the calling agent.

        Args:
            kind: a short category, e.g. crowd_crush, collapse, fire, lost_child
            severity: none, low, high or critical
            description: what was seen
            lat: where, latitude in degrees
            lon: where, longitude in degrees
        """
        return store.log(kind, severity, description, lat, lon, reported_by=context.caller.id)

    def query(
        kind: str | None = None,
        min_severity: Severity | None = None,
        since: str | None = None,
        near: Near | None = None,
        limit: Annotated[int, Field(ge=1, le=MAX_LIMIT)] = 50,
    ) -> Incidents:
        """Find logged incidents, newest first.

        Args:
            kind: only this category
            min_severity: only this severity or worse (none < low < high < critical)
            since: only incidents logged at or after this ISO 8601 time (UTC if no offset)
            near: only located incidents within radius_m metres of lat, lon
            limit: at most this many
        """
        found = store.query(kind, min_severity, since, near, limit)
        return Incidents(incidents=found, count=len(found))

    return [
        spec_from_function(
            log,
            name="incidents.log",
            scopes=["incidents:write"],
            retry=RetrySpec(attempts=3, retry_if=declared_transient),  # a locked database committed nothing
            side_effects=True,
            timeout_s=BUSY_TIMEOUT_S + 5,
        ),
        spec_from_function(
            query,
            name="incidents.query",
            scopes=["incidents:read"],
            idempotent=True,
            retry=2,
            timeout_s=BUSY_TIMEOUT_S + 5,
            untrusted_output=True,
        ),
    ]


__all__ = ["Incident", "IncidentLogged", "IncidentStore", "Incidents", "Near", "incident_tools"]
