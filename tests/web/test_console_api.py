"""The console's server without a browser: token, CSRF, the confirm step, static files, and the truth of a
period change on a row another administrator owns (in-process nodes over memlinks, Table 2's config)."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path
from typing import Any

import pytest

from uavbus import MemLink, Node
from uavbus.remote import RemoteCall
from uavbus.sim.build import REPO
from uavbus.sim.hitl import catalogue_for
from uavbus.tools.discover import g_offer
from uavbus.web.console import Console
from uavbus.web.server import CSRF_HEADER, make_app, plan

TABLE2 = REPO / "examples" / "configs" / "table2.json"
TOKEN = "a-token-of-the-operator-0123456789"
pytestmark = pytest.mark.timeout(60)


@pytest.fixture(scope="module")
def catalogue(program: Path) -> Path:
    return catalogue_for(program)


@pytest.fixture
def console(catalogue: Path) -> Any:
    node = Node(str(catalogue), config=str(TABLE2), node="gcs")
    c = Console(node)
    c.start()
    yield c
    c.stop()
    node.close()


def run_app(console: Console, token: str | None, body: Any) -> Any:
    from aiohttp.test_utils import TestClient, TestServer

    async def go() -> Any:
        client = TestClient(TestServer(make_app(console, token=token, csrf="csrf-secret")))
        await client.start_server()
        try:
            return await body(client)
        finally:
            await client.close()
    return asyncio.run(go())


def test_token_is_required_and_becomes_a_strict_cookie(console: Console) -> None:
    async def body(client: Any) -> None:
        r = await client.get("/api/fleet")
        assert r.status == 401 and "token" in await r.text()
        assert (await client.get("/")).status == 401
        assert (await client.get("/api/fleet", headers={"Authorization": "Bearer wrong"})).status == 401
        r = await client.get(f"/?token={TOKEN}", allow_redirects=False)
        assert r.status == 302 and r.headers["Location"] == "/"  # the token leaves the address bar
        cookie = r.headers["Set-Cookie"]
        assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
        r = await client.get("/api/fleet")  # the client kept the cookie
        assert r.status == 200 and (await r.json())["me"] == "gcs1"
        r = await client.get("/api/info", headers={"Authorization": f"Bearer {TOKEN}"})
        assert r.status == 200
    run_app(console, TOKEN, body)


def test_writes_need_the_csrf_header_json_and_the_same_origin(console: Console) -> None:
    add = {"op": "admin_add", "content": "gpsOut", "source": "rmax1ob1", "destination": "gcs1", "period_ms": 100}

    async def body(client: Any) -> None:
        page = await (await client.get("/")).text()
        assert 'content="csrf-secret"' in page
        r = await client.post("/api/prepare", json=add)
        assert r.status == 403 and "CSRF" in (await r.json())["error"]
        r = await client.post("/api/prepare", data="op=admin_add", headers={CSRF_HEADER: "csrf-secret",
                                                                         "Content-Type": "text/plain"})
        assert r.status == 415  # what a cross-site form could send
        r = await client.post("/api/prepare", json=add, headers={CSRF_HEADER: "csrf-secret",
                                                                 "Origin": "http://evil.example"})
        assert r.status == 403 and "origin" in (await r.json())["error"]
        assert console.admin.rows() == []
        r = await client.get("/api/admin")
        assert (await r.json())["rows"] == []
    run_app(console, None, body)


def test_without_a_token_only_loopback_names_reach_the_console(console: Console) -> None:
    """DNS rebinding: a page of evil.example whose name now points at 127.0.0.1 is same-origin with itself,
    so it could read the page's CSRF value and send it with a matching Origin; its Host header gives it away."""
    add = {"op": "admin_add", "content": "gpsOut", "source": "rmax1ob1", "destination": "gcs1", "period_ms": 100}

    async def body(client: Any) -> None:
        evil = {"Host": "evil.example:8080"}
        r = await client.get("/", headers=evil)
        assert r.status == 403 and "not a loopback name" in await r.text()
        assert "csrf-secret" not in await r.text()
        assert (await client.get("/api/fleet", headers=evil)).status == 403
        r = await client.post("/api/prepare", json=add, headers={**evil, "Origin": "http://evil.example:8080",
                                                                 CSRF_HEADER: "csrf-secret"})
        assert r.status == 403
        assert console.admin.rows() == []
        for ok_host in ("127.0.0.1:8080", "localhost:8080", "[::1]:8080", "127.0.0.2"):
            assert (await client.get("/api/info", headers={"Host": ok_host})).status == 200, ok_host
    run_app(console, None, body)

    async def with_token(client: Any) -> None:  # a token decides beyond localhost, whatever name was used
        r = await client.get("/api/info", headers={"Host": "uav-gcs.lan:8080", "Authorization": f"Bearer {TOKEN}"})
        assert r.status == 200
    run_app(console, TOKEN, with_token)


def test_the_token_beyond_localhost(tmp_path: Path) -> None:
    """What `uavbus web` and ServerThread listen with: none needed on loopback, one made beyond it (tests
    listen on 127.0.0.1 only, so the decision is tested here), a token file's first line everywhere."""
    from uavbus.web.server import ServerThread, listen_token

    assert listen_token("127.0.0.1", None) is None and listen_token("localhost", None) is None
    made = [listen_token(h, None) for h in ("0.0.0.0", "192.168.1.20", "::")]
    assert all(t is not None and len(t) >= 16 for t in made) and len(set(made)) == 3
    f = tmp_path / "token"
    f.write_text(TOKEN + "\nignored\n")
    assert listen_token("127.0.0.1", str(f)) == TOKEN == listen_token("0.0.0.0", str(f))
    with pytest.raises(SystemExit, match=r"nosuch:1: cannot read the token"):
        listen_token("0.0.0.0", str(tmp_path / "nosuch"))
    assert ServerThread(None, "127.0.0.1").token is None
    wide = ServerThread(None, "0.0.0.0")
    assert wide.token is not None and len(wide.token) >= 16


def test_nothing_happens_before_confirm_and_a_confirm_works_once(console: Console) -> None:
    h = {CSRF_HEADER: "csrf-secret"}

    async def body(client: Any) -> None:
        r = await client.post("/api/prepare", headers=h, json={"op": "admin_add", "content": "nosuch", "source": "a",
                                                                "destination": "b", "period_ms": 10})
        assert r.status == 400 and "not in catalogue" in (await r.json())["error"]
        r = await client.post("/api/prepare", headers=h, json={"op": "admin_add", "content": "gpsOut",
                                                                "source": "rmax1ob1", "destination": "gcs1",
                                                                "period_ms": 100, "activate": False})
        p = await r.json()
        assert p["what"] == "add publication gpsOut rmax1ob1 -> gcs1 every 100 ms to gcs1's administration table"
        assert (await (await client.get("/api/admin")).json())["rows"] == []  # prepared, not done
        r = await client.post("/api/confirm", headers=h, json={"confirm": p["confirm"]})
        assert (await r.json())["row"] == 0
        rows = (await (await client.get("/api/admin")).json())["rows"]
        assert [(x["content"], x["status"], x["type"]) for x in rows] == [("gpsOut", "inactive", "publication")]
        r = await client.post("/api/confirm", headers=h, json={"confirm": p["confirm"]})
        assert r.status == 409  # once
        r = await client.post("/api/prepare", headers=h, json={"op": "admin_remove", "row": 0})
        cid = (await r.json())["confirm"]
        await client.post("/api/cancel", headers=h, json={"confirm": cid})
        assert (await client.post("/api/confirm", headers=h, json={"confirm": cid})).status == 409
        assert len((await (await client.get("/api/admin")).json())["rows"]) == 1  # cancelled: still there
    run_app(console, None, body)


def test_static_files_come_from_the_package_only(console: Console) -> None:
    async def body(client: Any) -> None:
        r = await client.get("/static/app.js")
        assert r.status == 200 and "prepare" in await r.text() and r.content_type == "text/javascript"
        assert "default-src 'self'" in r.headers["Content-Security-Policy"]
        for bad in ("/static/..%2Fserver.py", "/static/__init__.py", "/static/.hidden.js"):
            assert (await client.get(bad)).status == 404, bad
    run_app(console, None, body)
    page = (REPO / "runtime_py" / "uavbus" / "web" / "static" / "index.html").read_text()
    js = (REPO / "runtime_py" / "uavbus" / "web" / "static" / "app.js").read_text()
    assert "http://" not in page + js and "https://" not in page + js  # nothing fetched from elsewhere


def _one(call: RemoteCall) -> Any:
    return (yield call)


def drive(nodes: list[Node], task: Any, timeout: float = 10.0) -> Any:
    """Runs a console task while polling every in-process node (the console's thread is not started)."""
    deadline = time.monotonic() + timeout
    if isinstance(task, RemoteCall):
        task = _one(task)
    call = next(task)
    while True:
        while not call.step():
            for n in nodes:
                n.poll(0)
            time.sleep(0.001)
            assert time.monotonic() < deadline, "the task took too long"
        try:
            call = task.send(call.result())
        except StopIteration as stop:
            return stop.value


def test_period_change_on_a_row_another_administrator_owns_says_temporary(catalogue: Path) -> None:
    gcs = Node(str(catalogue), config=str(TABLE2), node="gcs")
    air = Node(str(catalogue), config=str(TABLE2), node="primary")
    sec = Node(str(catalogue), config=str(TABLE2), node="secondary")
    nodes = [gcs, air, sec]
    try:
        MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1")
        MemLink(air, "onboardPortIPC", sec, "onboard2PortIPC")
        air.bind("gpsOut")
        sec.bind("gpsOut")
        other = sec.admin("rmax1ob2")  # another administrator keeps a flow at rmax1ob1
        row = other.add("gpsOut", "rmax1ob1", "rmax1ob2", 100, "publication")
        other.activate(row)
        deadline = time.monotonic() + 5
        while other.status(row)["status"] != "active":
            for n in nodes:
                n.poll(0.001)
            assert time.monotonic() < deadline, other.status(row)
        console = Console(gcs)  # not started: this test drives the nodes itself
        ps = drive(nodes, console.remote("rmax1ob1").begin("table", "pubsub"))
        (owned,) = [r for r in ps if r["content"] == "gpsOut"]
        assert owned["owner"] == "rmax1ob2"
        what, run = plan(console, {"op": "set_period", "entity": "rmax1ob1", "row": owned["row"], "period_ms": 40})
        assert what == f"set rmax1ob1's publish/subscribe row {owned['row']} to every 40 ms"
        result = drive(nodes, run())
        assert result["temporary"] is True and result["owner"] == "rmax1ob2"
        assert result["message"].startswith("temporary change:") and "Not done." in result["message"]
        # ... and it is so: the owner's next renewal puts its period back.
        deadline = time.monotonic() + 3
        while True:
            for n in nodes:
                n.poll(0.002)
            period = [r for r in air.pubsub_rows("rmax1ob1") if r["content"] == "gpsOut"][0]["period_ms"]
            if period == 100:
                break
            assert time.monotonic() < deadline, f"still {period} ms"
        # Discovery of what rmax1ob1 offers: gpsOut hosted (bound here), a directory it does not host is not.
        offer = drive(nodes, g_offer(console.remote("rmax1ob1"), gcs.catalogue, ["gpsOut", "imuOut"]))
        by = {r["name"]: r for r in offer["instances"]}
        assert by["gpsOut"]["bound"] and "publication to rmax1ob2 every 100 ms" in by["gpsOut"]["flows"]
        assert not by["imuOut"]["bound"] and by["imuOut"]["probe"] == "unbound"

        # The fleet view's states: an entity learned at run time, then removed (revoked), never silently gone.
        def fleet_state(name: str) -> tuple[str, str] | None:
            for e in console.fleet_now()["entities"]:
                if e["name"] == name:
                    return e["state"], e["origin"]
            return None

        def settle(cond: Any) -> None:
            deadline = time.monotonic() + 5
            while not cond():
                for n in nodes:
                    n.poll(0.002)
                assert time.monotonic() < deadline
        member = air.membership("rmax1ob1")
        member.request("add_entity", "gcs1", "rmax9")
        settle(lambda: fleet_state("rmax9") is not None)
        assert fleet_state("rmax9") == ("stale", "learned")  # known, never heard
        assert fleet_state("rmax1ob1")[0] == "alive" and fleet_state("fcs20") == ("stale", "configured")
        member.request("remove_entity", "gcs1", "rmax9")
        settle(lambda: fleet_state("rmax9") == ("revoked", "learned"))
    finally:
        for n in nodes:
            n.close()


def test_uavbus_web_process_needs_its_token(catalogue: Path, tmp_path: Path) -> None:
    """The command itself: a token file makes every request need it (beyond localhost one is made when none is
    given: `_is_loopback` decides; the tests listen on 127.0.0.1 only); a short token is refused in one line."""
    import subprocess
    import sys
    import urllib.error
    import urllib.request

    from uavbus.web.server import _is_loopback

    assert _is_loopback("127.0.0.1") and _is_loopback("localhost") and _is_loopback("::1")
    assert not _is_loopback("0.0.0.0") and not _is_loopback("192.168.1.20")
    token = tmp_path / "token"
    token.write_text(TOKEN + "\n")
    url_file = tmp_path / "url"
    argv = [sys.executable, "-m", "uavbus.cli", "web", "--config", str(TABLE2), "--node", "gcs", "--catalogue",
            str(catalogue), "--http", "127.0.0.1:0", "--url-file", str(url_file)]
    proc = subprocess.Popen([*argv, "--token-file", str(token)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 30
        while not url_file.exists():
            assert proc.poll() is None and time.monotonic() < deadline, proc.stdout.read().decode() if proc.stdout else ""
            time.sleep(0.05)
        shown = url_file.read_text().strip()
        assert shown.endswith(f"?token={TOKEN}")
        base = shown.split("?")[0]
        with pytest.raises(urllib.error.HTTPError) as denied:
            urllib.request.urlopen(base + "api/info", timeout=10)
        assert denied.value.code == 401
        req = urllib.request.Request(base + "api/info", headers={"Authorization": f"Bearer {TOKEN}"})
        assert json.loads(urllib.request.urlopen(req, timeout=10).read())["me"] == "gcs1"
    finally:
        proc.terminate()
        proc.wait(10)
    token.write_text("short\n")
    bad = subprocess.run([*argv, "--token-file", str(token)], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and bad.stderr.strip() == f"uavbus web: {token}:1: the token must be at least 16 characters"
