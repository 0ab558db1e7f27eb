"""`uavbus web`: the operator's console in the browser (docs/web.md).

    uavbus web --config table2.json --node gcs --catalogue flightsw.catalogue.json [--port LINK=SPEC]...
               [--positions console.json] [--route on] [--http 127.0.0.1:8080] [--token-file FILE]
    uavbus web --log gcs1.ublog [--positions console.json]       (log review: a time slider, plots, map)

One process: the console's node (the C router through uavbus.Node, hosting the config's entities for
--node) on its own thread (console.py), and an aiohttp server on 127.0.0.1 by default. Every script and
style is in the package (uavbus/web/static); nothing is fetched from elsewhere.

Security (docs/web.md#security):
 - bound beyond localhost, every request needs the token (printed once, or read from --token-file): given
   as `?token=` once, it becomes a cookie (HttpOnly, SameSite=Strict); or `Authorization: Bearer`;
 - a write is two requests: `prepare` says in words what will happen and returns a one-time confirm id,
   `confirm` with that id does it. Both are POSTs with a JSON body and the page's CSRF header; a request
   from another origin is refused;
 - what the console writes leaves as this node's entity, so the target's policy judges it like any other
   request, and a refusal comes back with its reason.
"""

from __future__ import annotations

import argparse
import asyncio
import hmac
import ipaddress
import json
import os
import secrets
import signal
import sys
import time
from importlib import resources
from pathlib import Path
from typing import Any

from uavbus.tools.common import ArgumentParser, jsonable

STATIC_TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css"}
CSRF_HEADER = "X-Uavbus-Csrf"
COOKIE = "uavbus_token"


class ActionError(ValueError):
    """A prepared action that cannot be: the message says why (shown in the page)."""


def _is_loopback(host: str) -> bool:
    if host in ("localhost", ""):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _host_name(host_header: str) -> str:
    """The name in a Host header ("127.0.0.1:8080", "[::1]:8080", "localhost") without its port."""
    from urllib.parse import urlsplit

    try:
        return urlsplit("//" + host_header).hostname or ""
    except ValueError:
        return "\x00"  # not a host at all: matches nothing


def listen_token(host: str, token_file: str | None) -> str | None:
    """The token every request needs: the first line of `token_file` (at least 16 characters), else one made
    now when `host` is beyond localhost, else None (a loopback console may go without; docs/web.md#security)."""
    if token_file:
        try:
            lines = Path(token_file).read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            raise SystemExit(f"{token_file}:1: cannot read the token ({getattr(exc, 'strerror', None) or exc})") \
                from None
        token = lines[0].strip() if lines else ""
        if len(token) < 16:
            raise SystemExit(f"{token_file}:1: the token must be at least 16 characters")
        return token
    return None if _is_loopback(host) else secrets.token_urlsafe(24)


def _static(name: str) -> bytes:
    return resources.files("uavbus.web").joinpath("static", name).read_bytes()


def make_app(console: Any, *, token: str | None, csrf: str | None = None, review: Any = None) -> Any:
    """The aiohttp application over a started Console, or over a LogReview (`review`, console None: log
    review only). `token`: required on every request when set."""
    from aiohttp import web

    csrf = csrf or secrets.token_urlsafe(24)

    async def on_node(fn: Any, *args: Any) -> Any:
        return await asyncio.wrap_future(console.submit(fn, *args))

    @web.middleware
    async def guard(request: web.Request, handler: Any) -> web.StreamResponse:
        if token is None and not _is_loopback(_host_name(request.host)):
            # Without a token only the loopback names reach the console: a page of another site whose name
            # was re-pointed at 127.0.0.1 (DNS rebinding) is same-origin with itself, so the Origin and CSRF
            # checks below would let it read the CSRF value and write; its Host header still names that site.
            return web.Response(status=403, text=f"uavbus web: refused: Host {request.host!r} is not a loopback "
                                "name (open http://127.0.0.1:PORT/, or give the console a --token-file)\n")
        if token is not None:
            given = request.cookies.get(COOKIE, "")
            auth = request.headers.get("Authorization", "")
            if auth.startswith("Bearer "):
                given = auth[7:]
            query = request.query.get("token")
            if query is not None and hmac.compare_digest(query, token) and request.method == "GET":
                resp = web.HTTPFound(request.path)  # the token leaves the address bar at once
                resp.set_cookie(COOKIE, token, httponly=True, samesite="Strict")
                raise resp
            if not hmac.compare_digest(given, token):
                return web.Response(status=401, text="uavbus web: this console needs its token: open "
                                    "http://HOST:PORT/?token=TOKEN (printed when it started, or --token-file)\n")
        if request.method == "POST":
            origin = request.headers.get("Origin")
            if origin is not None and origin != f"{request.scheme}://{request.host}":
                return web.json_response({"error": f"refused: a request from another origin ({origin})"}, status=403)
            if not hmac.compare_digest(request.headers.get(CSRF_HEADER, ""), csrf):
                return web.json_response({"error": "refused: no CSRF header (reload the page)"}, status=403)
            if request.content_type != "application/json":
                return web.json_response({"error": "refused: the body must be JSON"}, status=415)
        resp = await handler(request)
        resp.headers.setdefault("Cache-Control", "no-store")
        resp.headers.setdefault("X-Content-Type-Options", "nosniff")
        resp.headers.setdefault("X-Frame-Options", "DENY")
        resp.headers.setdefault("Content-Security-Policy", "default-src 'self'; img-src 'self' data:; "
                                "style-src 'self'; script-src 'self'; connect-src 'self'")
        return resp

    async def index(request: web.Request) -> web.Response:
        html = _static("index.html").decode("utf-8").replace("{{CSRF}}", csrf)
        return web.Response(text=html, content_type="text/html")

    async def static(request: web.Request) -> web.Response:
        name = request.match_info["name"]
        suffix = Path(name).suffix
        if "/" in name or name.startswith(".") or suffix not in STATIC_TYPES:
            raise web.HTTPNotFound()
        try:
            body = _static(name)
        except (FileNotFoundError, IsADirectoryError):
            raise web.HTTPNotFound() from None
        return web.Response(body=body, content_type=STATIC_TYPES[suffix])

    def ok(data: Any) -> web.Response:
        return web.json_response(jsonable(data))

    def keys_of(request: web.Request) -> list[tuple[str, str, str]]:
        keys = []
        for k in request.query.getall("k", []):
            content, _, rest = k.partition("@")
            source, _, fld = rest.partition(":")
            if content and source and fld:
                keys.append((content, source, fld))
        return keys

    if console is None:  # log review: the pages and the log's data, nothing that writes
        async def review_info(request: web.Request) -> web.Response:
            return ok(review.info())

        async def review_series(request: web.Request) -> web.Response:
            return ok(review.series(keys_of(request), float(request.query.get("t0", review.t0)),
                                    float(request.query.get("t1", review.t1))))

        async def review_positions(request: web.Request) -> web.Response:
            return ok(review.positions(float(request.query.get("t", review.t1))))

        app = web.Application(middlewares=[guard])
        app.router.add_get("/", index)
        app.router.add_get("/static/{name}", static)
        app.router.add_get("/api/info", review_info)
        app.router.add_get("/api/review/series", review_series)
        app.router.add_get("/api/review/positions", review_positions)
        return app
    cat = console.node.catalogue

    def fail(exc: BaseException, status: int = 200) -> web.Response:
        from uavbus.errors import UbError

        reason = getattr(exc, "reason", None)
        text = exc.detail if isinstance(exc, UbError) else str(exc)
        return web.json_response({"error": text, "reason": reason}, status=status)

    async def info(request: web.Request) -> web.Response:
        def now() -> dict[str, Any]:
            cfg = console.node.config
            return {"me": console.me, "system": getattr(cfg, "system", ""), "catalogue": cat.name,
                    "configured": console.configured, "routing": console.node.routing.enabled,
                    "positions": console.positions_spec, "administrators": console.admin_now()["administrators"]}
        return ok(await on_node(now))

    async def fleet(request: web.Request) -> web.Response:
        return ok(await on_node(console.fleet_now))

    async def admin(request: web.Request) -> web.Response:
        return ok(await on_node(console.admin_now))

    async def flows(request: web.Request) -> web.Response:
        window = float(request.query.get("window", "5"))
        return ok(await on_node(console.flows_now, window))

    async def series(request: web.Request) -> web.Response:
        since = float(request.query.get("since", "0") or 0)
        return ok(await on_node(console.series_now, keys_of(request), since))

    async def catalogue(request: web.Request) -> web.Response:
        from uavbus.units import units_of

        out = []
        for inst in cat:
            out.append({"name": inst.name, "type": inst.type.name, "size": inst.type.packed_size,
                        "units": units_of(cat, inst.type)})
        return ok({"name": cat.name, "instances": out})

    async def entity_table(request: web.Request) -> web.Response:
        entity, table = request.match_info["entity"], request.match_info["table"]
        try:
            rows = await on_node(lambda: _g_one(console.remote(entity).begin("table", table)))
        except Exception as exc:  # noqa: BLE001 - shown with its reason
            return fail(exc)
        return ok({"entity": entity, "table": table, "rows": rows, "t": time.time()})

    async def entity_dir(request: web.Request) -> web.Response:
        from uavbus.web.console import describe_fields

        entity, name = request.match_info["entity"], request.match_info["name"]
        try:
            value = await on_node(lambda: _g_one(console.remote(entity).begin("get", name)))
            rows = describe_fields(cat, name, value)
        except Exception as exc:  # noqa: BLE001
            return fail(exc)
        return ok({"entity": entity, "name": name, "fields": rows, "value": value, "t": time.time()})

    async def entity_offer(request: web.Request) -> web.Response:
        from uavbus.tools.discover import g_offer

        entity = request.match_info["entity"]
        try:
            offer = await on_node(lambda: g_offer(console.remote(entity), cat))
        except Exception as exc:  # noqa: BLE001
            return fail(exc)
        return ok(offer)

    async def prepare(request: web.Request) -> web.Response:
        try:
            body = await request.json()
            if not isinstance(body, dict):
                raise ActionError("the body must be a JSON object")
            return ok(await on_node(lambda: console.prepare(*plan(console, body))))
        except (ActionError, ValueError, KeyError, TypeError, LookupError) as exc:
            return fail(exc, 400)

    async def confirm(request: web.Request) -> web.Response:
        body = await request.json()
        cid = body.get("confirm", "") if isinstance(body, dict) else ""
        pending = await on_node(console.take, str(cid))
        if pending is None:
            return web.json_response({"error": "nothing to confirm: the action expired or was done already; "
                                               "prepare it again"}, status=409)
        try:
            result = await on_node(pending.run)
        except Exception as exc:  # noqa: BLE001 - a refusal or a silence: shown with its reason
            console.events.append({"t": time.time(), "what": pending.what, "error": str(exc)})
            return fail(exc)
        console.events.append({"t": time.time(), "what": pending.what, "result": result})
        return ok(result)

    async def cancel(request: web.Request) -> web.Response:
        body = await request.json()
        await on_node(console.take, str(body.get("confirm", "")) if isinstance(body, dict) else "")
        return ok({"cancelled": True})

    app = web.Application(middlewares=[guard])
    app.router.add_get("/", index)
    app.router.add_get("/static/{name}", static)
    app.router.add_get("/api/info", info)
    app.router.add_get("/api/fleet", fleet)
    app.router.add_get("/api/admin", admin)
    app.router.add_get("/api/flows", flows)
    app.router.add_get("/api/series", series)
    app.router.add_get("/api/catalogue", catalogue)
    app.router.add_get("/api/entity/{entity}/table/{table}", entity_table)
    app.router.add_get("/api/entity/{entity}/dir/{name}", entity_dir)
    app.router.add_get("/api/entity/{entity}/offer", entity_offer)
    app.router.add_post("/api/prepare", prepare)
    app.router.add_post("/api/confirm", confirm)
    app.router.add_post("/api/cancel", cancel)
    return app


def _g_one(call: Any) -> Any:
    """A task (run on the node thread) that waits for one RemoteCall and returns its result."""
    value = yield call
    return value


# -- actions: what a prepare request asks, in words, and the function that does it on confirm ---------------
def _int(body: dict[str, Any], key: str, lo: int = 0, hi: int = 2**31 - 1) -> int:
    try:
        v = int(body[key])
    except KeyError:
        raise ActionError(f"missing {key!r}") from None
    except (TypeError, ValueError):
        raise ActionError(f"{key}: {body[key]!r} is not a whole number") from None
    if not lo <= v <= hi:
        raise ActionError(f"{key}: {v} is out of range ({lo}..{hi})")
    return v


def _text(body: dict[str, Any], key: str) -> str:
    v = body.get(key)
    if not isinstance(v, str) or not v.strip():
        raise ActionError(f"missing {key!r}")
    return v.strip()


def plan(console: Any, body: dict[str, Any]) -> tuple[str, Any]:
    """(the sentence the confirm step shows, the function that does it). Runs on the node thread."""
    op = body.get("op")
    node, cat, me = console.node, console.node.catalogue, console.me
    adm = console.admin
    if op == "admin_add":
        content, source, dest = _text(body, "content"), _text(body, "source"), _text(body, "destination")
        if cat.find(content) is None:
            raise ActionError(f"content {content!r}: not in catalogue {cat.name}")
        period = _int(body, "period_ms", 1)
        kind = body.get("kind", "publication")
        if kind not in ("publication", "subscription"):
            raise ActionError(f"type {kind!r}: publication or subscription")
        activate = bool(body.get("activate", True))

        def add() -> dict[str, Any]:
            if dest in node.local_entities:
                node.bind(content)  # storage for what arrives here: deliveries, plots, rates
            row = adm.add(content, source, dest, period, kind)
            if activate:
                adm.activate(row)
            return {"row": row, "message": f"row {row} added" + (" and activated: its request is out; the status "
                                                                  "column follows the answers" if activate else
                                                                  " (inactive: activate it to send the request)")}
        return (f"add {kind} {content} {source} -> {dest} every {period} ms to {me}'s administration table"
                + (" and activate it" if activate else ""), add)
    if op in ("admin_activate", "admin_deactivate", "admin_remove"):
        row = _int(body, "row", 0, 255)
        st = adm.status(row)  # NotFoundError if there is no such row
        label = f"row {row} ({st['content']} {st.get('source')} -> {st.get('destination')})"
        verb = op.split("_")[1]

        def act() -> dict[str, Any]:
            getattr(adm, verb)(row)
            return {"row": row, "message": f"{label}: {verb}d" if verb != "remove" else f"{label}: removed"}
        return f"{verb} administration {label}", act
    if op == "admin_period":
        row, period = _int(body, "row", 0, 255), _int(body, "period_ms", 1)
        st = adm.status(row)

        def period_change() -> Any:
            changed = yield console.remote(me).begin("set_admin_row", row, period_ms=period)
            return {"row": row, "changed": changed,
                    "message": f"row {row}: every {period} ms (its renewals carry the new period: a lasting change)"
                    if changed else f"row {row}: already every {period} ms"}
        return f"change administration row {row} ({st['content']}) from {st.get('period_ms')} ms to {period} ms", \
            period_change
    if op == "write":
        entity, name = _text(body, "entity"), _text(body, "name")
        if "value" not in body:
            raise ActionError("missing 'value'")
        value = body["value"]
        from uavbus.remote import split_name

        split_name(cat, name)  # NotFoundError: not a catalogued directory

        def write() -> Any:
            r = console.remote(entity)
            changed = yield r.begin("set", name, value)
            back = yield r.begin("get", name)
            return {"changed": changed, "read_back": back,
                    "message": (f"{entity}: {name} written; read back over the bus: {json.dumps(jsonable(back))}"
                                if changed else f"{entity}: {name} unchanged (it already was so)")}
        return f"write {name} = {json.dumps(value)} into {entity}", write
    if op == "set_period":
        entity, row, period = _text(body, "entity"), _int(body, "row", 0, 65535), _int(body, "period_ms", 1)

        def set_period() -> Any:
            from uavbus.tools.changes import g_set_period

            return g_set_period(node, console.remote(entity), row, period, me, console.admin)
        return f"set {entity}'s publish/subscribe row {row} to every {period} ms", set_period
    if op == "set_mask":
        entity, dest, mask = _text(body, "entity"), _text(body, "dest"), _text(body, "mask")

        def set_mask() -> Any:
            changed = yield console.remote(entity).begin("set_mask", dest, mask)
            return {"changed": changed, "message": f"{entity}: mask toward {dest} = {mask} (pinned)"}
        return f"set {entity}'s link mask toward {dest} to {mask} (pinned: routing leaves it)", set_mask
    raise ActionError(f"op {op!r}: one of admin_add, admin_activate, admin_deactivate, admin_remove, admin_period, "
                      "write, set_period, set_mask")


# -- the command ----------------------------------------------------------------------------------------------
def parse_positions(args: argparse.Namespace) -> dict[str, str]:
    out: dict[str, str] = {}
    if args.positions:
        try:
            doc = json.loads(Path(args.positions).read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            raise SystemExit(f"{args.positions}:{exc.lineno}: not JSON ({exc.msg})") from None
        pos = doc.get("positions", doc) if isinstance(doc, dict) else None
        if not isinstance(pos, dict) or not all(isinstance(v, str) for v in pos.values()):
            raise SystemExit(f"{args.positions}:1: expected {{\"positions\": {{\"ENTITY\": \"CONTENT.FIELD\", "
                             "\"*\": ...}}}")
        out.update(pos)
    for item in args.position:
        ent, eq, spec = item.partition("=")
        if not eq or not spec:
            raise SystemExit(f"--position {item}: expected ENTITY=CONTENT[.FIELD], e.g. "
                             "rmax1ob1=navFilterState.positionNed ('*' for every other entity)")
        out[ent] = spec
    return out


def main(argv: list[str] | None = None) -> int:
    from uavbus.tools.source import add_node_args, open_node

    p = ArgumentParser(prog="uavbus web", description="the operator's console in the browser (docs/web.md)")
    add_node_args(p)
    p.add_argument("--log", help="review this .ublog instead of joining the bus: a time slider, the same plots "
                                 "and map (no node, nothing written)")
    p.add_argument("--http", default="127.0.0.1:8080", metavar="HOST:PORT",
                   help="where the console listens (default 127.0.0.1:8080; port 0: any free port)")
    p.add_argument("--token-file", help="the token (first line) every request needs; required to listen beyond "
                                        "localhost unless one is made (printed)")
    p.add_argument("--positions", help="JSON {\"positions\": {ENTITY: \"CONTENT.FIELD\", \"*\": ...}}: where each "
                                       "entity's position is read (a vector x/y/z north-east-down, or lat/lon)")
    p.add_argument("--position", action="append", default=[], metavar="ENTITY=CONTENT.FIELD")
    p.add_argument("--route", choices=("on", "off"), default="off",
                   help="run the routing engine (learned entities, routes); the vehicles run it too")
    p.add_argument("--admin", help="the local entity whose administration table the console drives (default: the "
                                   "first hosted)")
    p.add_argument("--url-file", help="write the console's address here once it listens (scripts, tests)")
    args = p.parse_args(argv)
    positions = parse_positions(args)
    host, _, port_text = args.http.rpartition(":")
    if not port_text.isdigit():
        raise SystemExit(f"--http {args.http}: expected HOST:PORT, e.g. 127.0.0.1:8080")
    host = host or "127.0.0.1"
    token = listen_token(host, args.token_file)
    try:
        import aiohttp  # noqa: F401
    except ImportError:
        raise SystemExit("uavbus web needs aiohttp: pip install 'uavbus[web]'") from None

    if args.log:
        from uavbus.web.review import LogReview

        review = LogReview(args.log, positions)
        asyncio.run(_serve(None, host, int(port_text), token, args.url_file, review=review))
        return 0
    if not (args.config and args.node):
        raise SystemExit("give --config FILE --node NAME (the console's node), or --log FILE to review a log")
    session = open_node(args)
    if args.route == "on":
        session.node.enable_routing()
    from uavbus.web.console import Console

    console = Console(session.node, admin_entity=args.admin, positions=positions)
    console.start()
    try:
        asyncio.run(_serve(console, host, int(port_text), token, args.url_file))
    finally:
        console.stop()
        session.close()
    return 0


async def _serve(console: Any, host: str, port: int, token: str | None, url_file: str | None,
                 review: Any = None) -> None:
    from aiohttp import web

    app = make_app(console, token=token, review=review)
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    try:
        await site.start()
    except OSError as exc:
        await runner.cleanup()
        raise OSError(exc.errno, f"cannot listen on {host}:{port}: {exc.strerror}") from None
    bound = runner.addresses[0][1] if runner.addresses else port
    url = f"http://{host}:{bound}/"
    shown = url + (f"?token={token}" if token else "")
    what = f"console of {console.me}" if console is not None else f"review of {review.path.name}"
    print(f"uavbus web: {what} at {shown}", flush=True)
    if url_file:
        tmp = Path(url_file + ".tmp")
        tmp.write_text(shown + "\n", encoding="utf-8")
        os.replace(tmp, url_file)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop.set)
        except (NotImplementedError, RuntimeError):
            pass
    try:
        await stop.wait()
    finally:
        await runner.cleanup()
    print("uavbus web: stopped", file=sys.stderr, flush=True)


class ServerThread:
    """The console's web server on a thread of its own (its own asyncio loop), for a program whose main loop
    drives the node itself (a simulation): pair it with `Console.pump()` called from that loop.

        srv = ServerThread(console, "127.0.0.1", 0)
        srv.start()          # srv.url once it listens
        ...
        srv.stop()
    """

    def __init__(self, console: Any, host: str = "127.0.0.1", port: int = 0, token: str | None = None) -> None:
        import threading

        # Beyond localhost a token, as for `uavbus web` (made here when none is given; it is in self.url).
        self.console, self.host, self.port = console, host, port
        self.token = token if token is not None else None if _is_loopback(host) else secrets.token_urlsafe(24)
        self.url = ""
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._run, name="uavbus-web", daemon=True)

    def start(self, timeout: float = 10.0) -> str:
        self._thread.start()
        if not self._ready.wait(timeout):
            raise RuntimeError("uavbus web: the server did not start")
        if self._error is not None:
            raise self._error
        return self.url

    def _run(self) -> None:
        asyncio.run(self._main())

    async def _main(self) -> None:
        from aiohttp import web

        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        runner = web.AppRunner(make_app(self.console, token=self.token), access_log=None)
        try:
            await runner.setup()
            await web.TCPSite(runner, self.host, self.port).start()
            port = runner.addresses[0][1]
            self.url = f"http://{self.host}:{port}/" + (f"?token={self.token}" if self.token else "")
        except BaseException as exc:  # noqa: BLE001 - reported by start()
            self._error = exc
            self._ready.set()
            await runner.cleanup()
            return
        self._ready.set()
        try:
            await self._stop.wait()
        finally:
            await runner.cleanup()

    def stop(self) -> None:
        """Stops the server; a second call (or one after it ended) does nothing."""
        if self._loop is not None and self._stop is not None and self._thread.is_alive():
            try:
                self._loop.call_soon_threadsafe(self._stop.set)
            except RuntimeError:  # its loop ended meanwhile
                pass
        if self._thread.ident is not None:
            self._thread.join(5.0)
