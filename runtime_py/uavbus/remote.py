"""The variable browser over the bus: read and change any directory and table of a remote entity.

    gcs = Node("flightsw.catalogue.json", "table2.json", node="gcs")
    fcs = gcs.remote("fcs20")
    fcs.get("gpsOutBackup")               # the whole directory, read once (dict)
    fcs.get("onboardSet.mode")            # one field
    fcs.set("onboardSet.mode", 3)         # writes only the bytes of that field
    fcs.tables()                          # entities, links, pubsub rows, admin rows of fcs20
    fcs.set_period(row=0, period_ms=50)   # a publish/subscribe row's rate

Every call is one or more INSPECT requests (ub_inspect.h, docs/inspect.md) made by the C requester
attached to the node: resent every `retry_ms` until answered; the node is polled meanwhile. A NACK
raises RefusedError (its `reason`, e.g. "not_authorized"); silence until `timeout` NoAnswerError.
`Remote.begin()` starts any of these without blocking (a RemoteCall the caller steps from its own loop), so
a console or a UI thread never waits on a silent entity.
"""

from __future__ import annotations

import re
import time
from collections.abc import Generator
from typing import TYPE_CHECKING, Any

from uavbus._bindings import ub_inspect, ub_link
from uavbus._bindings.ub_error import (FullError, InvalidArgumentError, NoAnswerError, NotFoundError, RefusedError,
                                      UbError)
from uavbus.catalogue import Instance, decode_type, encode_type

if TYPE_CHECKING:
    from uavbus.node import Node

TABLES = tuple(ub_inspect.TABLES)
PROBE_OFFSET = 0xFFFE  # past the end of any inspectable value (UB_MAX_PAYLOAD), below UB_INSPECT_END
_INDEX = re.compile(r"^([^\[\]]+)((?:\[\d+\])*)$")


def split_name(catalogue: Any, name: str) -> tuple[Instance, list[str | int]]:
    """"onboardSet.datum.latitudeDeg" -> (instance onboardSet, ["datum", "latitudeDeg"]): the longest
    dotted prefix that is a catalogued instance, then the field path (`name[2]` indexes an array)."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        inst = catalogue.find(".".join(parts[:k]))
        if inst is not None:
            path: list[str | int] = []
            for part in parts[k:]:
                m = _INDEX.match(part)
                if m is None:
                    raise InvalidArgumentError(f"{name!r}: '{part}' is not a field name (name or name[i])")
                path.append(m.group(1))
                path += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
            return inst, path
    raise NotFoundError(f"{name!r}: no directory of that name in the catalogue (try `uavbus dirs`)")


def _walk(value: Any, path: list[str | int], name: str) -> Any:
    for step in path:
        try:
            value = value[step]
        except (KeyError, IndexError, TypeError):
            raise NotFoundError(f"{name!r}: no field {step!r} there") from None
    return value


class RemoteCall:
    """One Remote operation in flight, for callers that must not block (a console's loop, a UI thread).

        call = node.remote("fcs20").begin("get", "imuOut.p")
        while not call.step():      # after each node.poll() of the caller's own loop
            node.poll(0.01)
        call.result()               # the value, or the RefusedError / NoAnswerError the blocking call raises

    Each step only looks at the requester's rows: the node must be polled by the caller meanwhile."""

    def __init__(self, gen: Generator[None, None, Any]) -> None:
        self._gen = gen
        self.done = False
        self._value: Any = None
        self._error: BaseException | None = None

    def step(self) -> bool:
        """Advances the operation as far as the answers received allow; True once it is finished."""
        if self.done:
            return True
        try:
            next(self._gen)
        except StopIteration as stop:
            self.done, self._value = True, stop.value
        except Exception as exc:  # noqa: BLE001 - kept for result(), raised there in the caller's context
            self.done, self._error = True, exc
        return self.done

    @classmethod
    def of_task(cls, task: Generator[Any, Any, Any]) -> RemoteCall:
        """One call over a task that yields RemoteCalls and gets each one's result back (or its exception
        thrown in): e.g. read a table, then change a row, then read back. Done when the task returns."""
        def run() -> Generator[None, None, Any]:
            try:
                call = next(task)
            except StopIteration as stop:
                return stop.value
            while True:
                while not call.step():
                    yield
                try:
                    try:
                        value = call.result()
                    except Exception as exc:  # noqa: BLE001 - the task may handle it
                        call = task.throw(exc)
                    else:
                        call = task.send(value)
                except StopIteration as stop:
                    return stop.value
        return cls(run())

    def cancel(self) -> None:
        """Drops the operation (its pending request row is forgotten)."""
        if not self.done:
            self._gen.close()
            self.done, self._error = True, NoAnswerError("cancelled")

    def result(self) -> Any:
        if not self.done:
            raise InvalidArgumentError("the remote call is still pending: step() it until it returns True")
        if self._error is not None:
            raise self._error
        return self._value


class Remote:
    """One remote entity, seen from `node` (requests leave from the node's first local entity).

    Every method blocks, polling the node until answered; `begin(method, ...)` starts the same operation
    without blocking (RemoteCall)."""

    def __init__(self, node: "Node", entity: str, timeout: float = 3.0) -> None:
        self.node = node
        self.entity = entity
        self.timeout = timeout
        self._c = node.inspect._requester()

    # -- the driver ---------------------------------------------------------------------------------
    # Each operation is a generator that yields while a request is unanswered: the blocking methods poll
    # the node between steps; begin() hands the generator to the caller's loop instead.
    def begin(self, method: str, *args: Any, **kw: Any) -> RemoteCall:
        """Starts `method` ("get", "set", "probe", "read_raw", "write_raw", "table", "tables",
        "set_period", "set_mask", "set_admin_row") without waiting; step the returned call after each node poll."""
        gen = getattr(self, "_g_" + method, None)
        if gen is None:
            raise InvalidArgumentError(f"Remote.begin({method!r}): not an operation of Remote")
        return RemoteCall(gen(*args, **kw))

    @staticmethod
    def all(calls: list[RemoteCall]) -> RemoteCall:
        """One call that is done when every one of `calls` is (their requests overlap); its result is `calls`."""
        def wait() -> Generator[None, None, list[RemoteCall]]:
            while not all([c.step() for c in calls]):
                yield
            return calls
        return RemoteCall(wait())

    def _run(self, gen: Generator[None, None, Any]) -> Any:
        call = RemoteCall(gen)
        while not call.step():
            self.node.poll(0.002)
        return call.result()

    # -- requests -----------------------------------------------------------------------------
    def _g_call(self, op: str, what: str, **kw: Any) -> Generator[None, None, dict[str, Any]]:
        deadline = time.monotonic() + self.timeout
        while True:  # every requester row may be busy (UB_MAX_INSPECT_REQUESTS): wait for one
            try:
                row = ub_inspect.ub_inspect_request(self._c, ub_inspect.spec(op, self.entity, **kw), self.node.now())
                break
            except FullError:
                if time.monotonic() > deadline:
                    raise NoAnswerError(f"{self.entity}: {what}: every inspection request row stayed busy for "
                                        f"{self.timeout:g} s") from None
                yield
        try:
            while True:
                r = ub_inspect.ub_inspect_result(self._c, row)
                if r["status"] != "pending":
                    break
                if time.monotonic() > deadline:
                    raise NoAnswerError(f"{self.entity}: {what}: no answer in {self.timeout:g} s "
                                        f"({r['attempts']} attempts; is there a route to it?)")
                yield
        finally:
            ub_inspect.ub_inspect_forget(self._c, row)
        if r["status"] == "failed":
            if r["reason"] in (None, "none"):
                raise NoAnswerError(f"{self.entity}: {what}: no answer after {r['attempts']} attempts")
            raise RefusedError(f"{self.entity}: {what}: refused ({r['reason']})", r["reason"])
        return r

    def _g_read_raw(self, content: str) -> Generator[None, None, bytes]:
        inst = self.node.catalogue.instance(content)
        out, offset = b"", 0
        while True:
            r = yield from self._g_call("read", f"read {content}", instance=inst.index, offset=offset)
            out += r["data"]
            if r["next"] == ub_inspect.END:
                return out
            offset = r["next"]

    def read_raw(self, content: str) -> bytes:
        """The packed image of directory `content`, read once (in chunks if it is long)."""
        return self._run(self._g_read_raw(content))

    def _g_get(self, name: str) -> Generator[None, None, Any]:
        inst, path = split_name(self.node.catalogue, name)
        value = decode_type(inst.type, (yield from self._g_read_raw(inst.name)))
        return _walk(value, path, name)

    def get(self, name: str) -> Any:
        """A directory (dict) or one field of it ("onboardSet.mode"), as the target holds it now."""
        return self._run(self._g_get(name))

    def _g_probe(self, content: str) -> Generator[None, None, str]:
        inst = self.node.catalogue.instance(content)
        try:
            # A READ past the end of any value: the target answers NO_SUCH_ROW only after it found the
            # directory hosted and the read permitted, so one short NACK tells without moving the value.
            yield from self._g_call("read", f"probe {content}", instance=inst.index, offset=PROBE_OFFSET)
        except RefusedError as exc:
            return "hosted" if exc.reason == "no_such_row" else str(exc.reason)
        return "hosted"

    def probe(self, content: str) -> str:
        """Whether the entity hosts directory `content` and lets this node read it, without reading it:
        "hosted", or the target's reason ("unbound": not hosted there, "not_authorized", "unknown_content",
        "layout": another layout of that name, "unsupported": too large to inspect)."""
        return self._run(self._g_probe(content))

    def _g_write_raw(self, content: str, offset: int, data: bytes) -> Generator[None, None, bool]:
        inst = self.node.catalogue.instance(content)
        changed = False
        for k in range(0, len(data), ub_inspect.CHUNK):
            part = data[k:k + ub_inspect.CHUNK]
            r = yield from self._g_call("write", f"write {content}", instance=inst.index, offset=offset + k, data=part)
            changed = changed or r["changed"]
        return changed

    def write_raw(self, content: str, offset: int, data: bytes) -> bool:
        """Writes `data` at `offset` of `content`'s packed image; True if the value changed."""
        return self._run(self._g_write_raw(content, offset, data))

    def _g_set(self, name: str, value: Any) -> Generator[None, None, bool]:
        inst, path = split_name(self.node.catalogue, name)
        before = yield from self._g_read_raw(inst.name)
        if path:
            whole = decode_type(inst.type, before)
            parent = _walk(whole, path[:-1], name)
            try:
                old = parent[path[-1]]
            except (KeyError, IndexError, TypeError):
                raise NotFoundError(f"{name!r}: no field {path[-1]!r} there") from None
            if isinstance(old, dict) or isinstance(old, list) and not isinstance(value, list):
                raise InvalidArgumentError(f"{name!r} is a structure or array: give a whole value or a leaf field")
            parent[path[-1]] = value
        else:
            whole = value
        after = encode_type(inst.type, whole)
        diff = [i for i in range(len(after)) if after[i] != before[i]]
        if not diff:
            return False
        lo, hi = diff[0], diff[-1] + 1
        return (yield from self._g_write_raw(inst.name, lo, after[lo:hi]))

    def set(self, name: str, value: Any) -> bool:
        """Writes a whole directory (`value` a dict) or one field ("onboardSet.mode", 3). Only the bytes
        that differ from the value just read travel, so a field write leaves the others as the target
        has them. Returns True if the target's value changed."""
        return self._run(self._g_set(name, value))

    def _g_table(self, table: str) -> Generator[None, None, list[dict[str, Any]]]:
        if table not in ub_inspect.TABLES:
            raise InvalidArgumentError(f"table {table!r}: one of {', '.join(TABLES)}")
        rows: list[dict[str, Any]] = []
        offset = 0
        while True:
            r = yield from self._g_call("list", f"list {table}", arg=ub_inspect.TABLES[table], offset=offset)
            rows += ub_inspect.decode_records(table, r["data"], self._dir_name)
            if r["next"] == ub_inspect.END:
                return rows
            offset = r["next"]

    def table(self, table: str) -> list[dict[str, Any]]:
        """One table of the entity: "entities" (with its masks), "links" (with counters), "pubsub", "admin"."""
        return self._run(self._g_table(table))

    def _g_tables(self) -> Generator[None, None, dict[str, list[dict[str, Any]]]]:
        out = {}
        for t in TABLES:
            out[t] = yield from self._g_table(t)
        return out

    def tables(self) -> dict[str, list[dict[str, Any]]]:
        """Every table of the entity, as table() reads them."""
        return self._run(self._g_tables())

    def _g_set_period(self, row: int, period_ms: int) -> Generator[None, None, bool]:
        r = yield from self._g_call("set_period", f"set period of pubsub row {row}", offset=row, value=period_ms)
        return bool(r["changed"])

    def set_period(self, row: int, period_ms: int) -> bool:
        """Changes the period of publish/subscribe row `row` (its "row" in table("pubsub"))."""
        return self._run(self._g_set_period(row, period_ms))

    def _g_set_mask(self, dest: str, mask: int | str) -> Generator[None, None, bool]:
        if isinstance(mask, str):
            try:
                mask = ub_link.ub_link_mask_parse(mask)
            except UbError:
                raise InvalidArgumentError(f"mask {mask!r}: expected the paper's notation, e.g. 0x00000011") from None
        r = yield from self._g_call("set_mask", f"set mask toward {dest}", subject=dest, value=mask)
        return bool(r["changed"])

    def set_mask(self, dest: str, mask: int | str) -> bool:
        """Sets (and pins) the entity's link mask toward `dest` ("0x00000011" or an int)."""
        return self._run(self._g_set_mask(dest, mask))

    def _g_set_admin_row(self, row: int, *, period_ms: int | None = None,
                         active: bool | None = None) -> Generator[None, None, bool]:
        changed = False
        if period_ms is not None:
            r = yield from self._g_call("admin_row", f"set period of admin row {row}",
                                        arg=ub_inspect.ADMIN_FIELDS["period"], offset=row, value=period_ms)
            changed |= bool(r["changed"])
        if active is not None:
            r = yield from self._g_call("admin_row", f"set admin row {row} active={active}",
                                        arg=ub_inspect.ADMIN_FIELDS["active"], offset=row, value=int(active))
            changed |= bool(r["changed"])
        return changed

    def set_admin_row(self, row: int, *, period_ms: int | None = None, active: bool | None = None) -> bool:
        """Changes administration row `row` of the entity in place: its period and/or activation flag."""
        return self._run(self._g_set_admin_row(row, period_ms=period_ms, active=active))

    def _dir_name(self, dir_id: bytes) -> str:
        try:
            return self.node.catalogue.instance_by_id(bytes(dir_id)).name
        except (KeyError, LookupError, ValueError):
            return bytes(dir_id).hex()

    def __repr__(self) -> str:
        return f"Remote({self.entity!r} via {self.node.name!r})"
