"""`make demo`, the console during the fleet step (issue 27): `uavbus web`'s pages on gcs1's node.

The fleet step's gcs1 is a Python node driven by the scenario's loop (uavbus.sim.fleet), so the console does
not get a thread of its own: its web server runs on a thread (uavbus.web.server.ServerThread) and the loop
pumps it (Console.pump()) between its own turns. Headless Chromium (Selenium, Debian's chromium-driver) opens
the pages while the fleet flies and writes

    demo-out/console_fleet.png   the map (local frame, gcs1 at its position) with links, routes and states
    demo-out/console_admin.png   gcs1's administration table: its four flows, their status

Each is a check; a missing browser fails the check with what to install, never the demo's other steps.

    from console_step import attach_console, finish_console
    state = attach_console(run, out, say)        # before run.run()
    console = finish_console(state, check)      # after it
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Callable

POSITIONS = {"*": "navFilterState.positionNed", "gcs1": "@0,-100", "gcs2": "@0,2300"}  # fleet12.yaml's stations
PUMP_S = 0.01
MAP_AT_S, ADMIN_AT_S = 11.0, 12.5  # after uav12 joined (8 s) and while gcs1 is still in range (it leaves at 15 s)
# The console shares this process (and its GIL) with gcs1, gcs2 and the scenario's loop: a browser polling
# its pages for the whole run delays the stations' hellos and bunches them (test_fleet_demo runs the step
# without the console for that reason). So Chromium starts only after uav12's join, whose 2 s the
# steady-state windows of fleet_report leave out anyway, and once both photographs are taken the server
# stops and the loop stops pumping the console: the rest of the run is the fleet's alone.
BROWSER_AT_S = 8.5
CHROMIUM, DRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"

Check = Callable[[str, bool, str], bool]


def attach_console(run: Any, out: Path, say: Callable[[str], None]) -> dict[str, Any]:
    state: dict[str, Any] = {"out": Path(out), "result": {}}
    # Imported now, before the fleet starts: imported at t=0 in the loop (aiohttp, selenium: ~0.7 s on a busy
    # machine) they held up the launcher's first `routes` sample, so the vehicles' start-up burst of
    # route updates fell into a short first window that the steady-state routing-frame check counted.
    import aiohttp  # noqa: F401
    import aiohttp.web  # noqa: F401

    from uavbus.web.console import Console
    from uavbus.web.server import ServerThread

    try:
        from selenium import webdriver  # noqa: F401
    except ImportError:  # said by the check when the browser thread fails
        pass

    def first(r: Any, t: float) -> None:
        try:
            console = Console(r.members["gcs1"].node, admin_entity="gcs1", positions=POSITIONS, fleet_period_s=2.0)
            server = ServerThread(console)
            url = server.start()
        except Exception as exc:  # noqa: BLE001 - reported as a failed check
            state["error"] = f"the console did not start: {type(exc).__name__}: {exc}"
            return
        state.update(console=console, server=server, url=url)
        say(f"  [console] gcs1's console at {url} (uavbus web's pages, pumped by the scenario's loop)")
        browser = threading.Thread(target=_browse, args=(run, url, state), name="console-shots", daemon=True)
        browser.start()
        state["browser"] = browser
        r.call_at(t + PUMP_S, pump)

    def pump(r: Any, t: float) -> None:
        if state.get("done"):  # photographed: the console leaves the loop to the fleet
            return
        state["console"].pump()
        r.call_at(t + PUMP_S, pump)

    run.call_at(0.0, first)
    return state


def _browse(run: Any, url: str, state: dict[str, Any]) -> None:
    res = state["result"]
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
        from selenium.webdriver.common.by import By

        if not (Path(CHROMIUM).exists() and Path(DRIVER).exists()):
            raise RuntimeError("no chromium/chromium-driver: apt-get install chromium chromium-driver (make setup)")
        opts = webdriver.ChromeOptions()
        for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,900"):
            opts.add_argument(a)
        opts.binary_location = CHROMIUM
        while run.t() < BROWSER_AT_S:
            time.sleep(0.1)
        driver = webdriver.Chrome(options=opts, service=Service(DRIVER))
        try:
            driver.get(url)
            rows = "return Array.from(document.querySelectorAll('#fleet-table tbody tr')).map(r => [r.dataset.entity, r.dataset.state]);"
            while run.t() < MAP_AT_S:
                time.sleep(0.1)
            # The machine is busy with fourteen nodes: give the page time to show what the console knows.
            deadline = time.monotonic() + 8.0
            while time.monotonic() < deadline:
                res["fleet"] = dict(driver.execute_script(rows))
                if sum(1 for s in res["fleet"].values() if s == "alive") >= 12 and "uav12" in res["fleet"]:
                    break
                time.sleep(0.3)
            driver.save_screenshot(str(state["out"] / "console_fleet.png"))
            driver.find_element(By.ID, "tab-admin").click()
            while run.t() < ADMIN_AT_S:
                time.sleep(0.1)
            admin = ("return Array.from(document.querySelectorAll('#admin-table tbody tr')).map(r => "
                     "[r.children[1].textContent, r.children[2].textContent, r.children[3].textContent, r.dataset.status]);")
            deadline = time.monotonic() + 8.0
            while time.monotonic() < deadline:
                res["admin"] = driver.execute_script(admin)
                if len(res["admin"]) >= 4:
                    break
                time.sleep(0.3)
            driver.save_screenshot(str(state["out"] / "console_admin.png"))
        finally:
            driver.quit()
    except Exception as exc:  # noqa: BLE001 - reported as a failed check
        res["error"] = f"{type(exc).__name__}: {exc}"
    finally:  # the server first: the loop still pumps, so a request in flight gets its answer
        if state.get("server") is not None:
            state["server"].stop()
        state["done"] = True


def finish_console(state: dict[str, Any], check: Check) -> dict[str, Any]:
    browser = state.get("browser")
    if browser is not None:
        browser.join(30.0)
    if state.get("server") is not None:
        state["server"].stop()
    res = state["result"]
    why = state.get("error") or res.get("error")
    fleet = res.get("fleet") or {}
    alive = sorted(n for n, s in fleet.items() if s == "alive")
    check("console: the fleet map shows the fleet (demo-out/console_fleet.png)",
          not why and len(alive) >= 12 and "uav12" in fleet,
          why or f"{len(fleet)} stations in the console of gcs1, {len(alive)} alive (uav12, which joined at 8 s, "
                 f"{'among them' if 'uav12' in fleet else 'missing'})")
    admin = res.get("admin") or []
    active = [r for r in admin if r[3] == "active"]
    check("console: gcs1's administration table (demo-out/console_admin.png)",
          not why and len(admin) >= 4 and len(active) >= 3,
          why or f"{len(admin)} rows, {len(active)} active: " + "; ".join(f"{c} {s}->{d} {st}" for c, s, d, st in admin))
    return {"fleet_states": fleet, "admin_rows": admin, "shots": ["console_fleet.png", "console_admin.png"],
            "error": why}
