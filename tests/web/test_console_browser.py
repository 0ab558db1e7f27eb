"""Issue 27 acceptance: the operator's console in a real browser against Table 2 running as processes.

rmax1ob1, rmax1ob2 and fcs20 are `uavbus_node` processes, gcs1 is `uavbus web` (its own process), every node
with automatic routes; headless Chromium drives the pages. One Table 2 serves the tests of this module in
order (fleet, a late vehicle, an administration row, a write, a plot); the refusal runs on its own Table 2
with a policy in which gcs1 is not an administrator.
"""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

from uavbus.web.table2 import ConsoleTable2

from web_testutil import identity_security, wait_for

pytestmark = pytest.mark.timeout(90)
TABLE2 = {"rmax1ob1", "rmax1ob2", "fcs20", "gcs1"}


@pytest.fixture(scope="module")
def table2(program: Path, tmp_path_factory: pytest.TempPathFactory) -> Any:
    with ConsoleTable2(tmp_path_factory.mktemp("table2"), program=program) as t:
        yield t


# -- page helpers ------------------------------------------------------------------------------------------
def load(driver: Any, url: str) -> None:
    driver.get(url)
    wait_for(lambda: driver.find_element(By.TAG_NAME, "body").get_attribute("data-ready") == "1", 10, "the page ready")


def tab(driver: Any, view: str) -> None:
    driver.find_element(By.ID, f"tab-{view}").click()
    wait_for(lambda: driver.find_element(By.ID, f"view-{view}").is_displayed(), 5, f"the {view} view")


def fleet_rows(driver: Any) -> dict[str, dict[str, str]]:
    out = {}
    for tr in driver.find_elements(By.CSS_SELECTOR, "#fleet-table tbody tr"):
        out[tr.get_attribute("data-entity")] = {"state": tr.get_attribute("data-state"),
                                                "origin": tr.get_attribute("data-origin"), "text": tr.text}
    return out


def row_text(driver: Any, css: str) -> str:
    """A row's text read in the page in one step: the tables are rebuilt as they refresh, so an element
    found first and read after may be gone (StaleElementReference under load)."""
    text = wait_for(lambda: driver.execute_script("const e = document.querySelector(arguments[0]); "
                                                  "return e ? e.innerText : null;", css), 10, css)
    return " ".join(text.split())  # cells: tab-separated in innerText, space-separated as .text gives them


def confirm(driver: Any, expect: str) -> str:
    """The confirm step: the dialog says what will happen; Confirm sends it. Returns the page's message."""
    box = wait_for(lambda: driver.find_element(By.ID, "confirm").is_displayed() and driver.find_element(By.ID, "confirm"),
                   5, "the confirm dialog")
    assert expect in box.text, box.text
    before = driver.find_element(By.ID, "message").text
    driver.find_element(By.ID, "confirm-yes").click()
    return wait_for(lambda: (m := driver.find_element(By.ID, "message").text) and m != before
                    and not m.startswith("sent;") and m, 10, "the answer to the confirmed action")


def answer_prompt(driver: Any, text: str) -> None:
    alert = wait_for(lambda: driver.switch_to.alert, 5, "the prompt")
    alert.send_keys(text)
    alert.accept()


def admin_add(driver: Any, content: str, source: str, dest: str, period: int, kind: str) -> None:
    tab(driver, "admin")
    for field, value in (("adm-content", content), ("adm-source", source), ("adm-destination", dest),
                         ("adm-period", str(period))):
        e = driver.find_element(By.ID, field)
        e.clear()
        e.send_keys(value)
    Select(driver.find_element(By.ID, "adm-kind")).select_by_visible_text(kind)
    driver.find_element(By.ID, "adm-add").click()


def admin_status(driver: Any, content: str, source: str) -> dict[str, str] | None:
    rows = driver.execute_script("""return Array.from(document.querySelectorAll('#admin-table tbody tr')).map(
        tr => [tr.dataset.status, ...Array.from(tr.children).map(td => td.textContent)]);""")
    for status, *cells in rows:
        if cells[1:3] == [content, source]:
            return {"row": cells[0], "status": status, "reason": cells[7], "period": cells[4]}
    return None


def click(driver: Any, xpath: str) -> None:
    """Clicks in the page itself (one step), so a table rebuilt meanwhile cannot leave a stale element."""
    ok = driver.execute_script("""const e = document.evaluate(arguments[0], document, null,
        XPathResult.FIRST_ORDERED_NODE_TYPE, null).singleNodeValue; if (e) setTimeout(() => e.click(), 0);
        return !!e;""", xpath)  # the click after the script returns: a prompt it opens must not block it
    assert ok, f"nothing to click at {xpath}"


def flow_rate(driver: Any, key: str) -> float | None:
    text = driver.execute_script("const e = document.querySelector(`#flows-table tr[data-flow='${arguments[0]}'] "
                                 "td.rate`); return e ? e.textContent : null;", key)
    return float(text) if text not in (None, "", "-") else None


# -- the tests -------------------------------------------------------------------------------------------------
def test_fleet_shows_table2_then_a_late_vehicle_without_reload(table2: ConsoleTable2, browser: Any,
                                                               shots: Path) -> None:
    load(browser, table2.url)
    rows = wait_for(lambda: (r := fleet_rows(browser)) and TABLE2 <= set(r) and
                    all(r[n]["state"] == "alive" for n in TABLE2) and r, 15, "Table 2's four entities alive")
    assert all(rows[n]["origin"] == "configured" for n in TABLE2)
    # The console's links, each with the neighbour heard on it, and a relayed entity drawn through rmax1ob1.
    def own_links() -> dict[str, str]:
        return {tr.get_attribute("data-link"): tr.text for tr in
                browser.find_elements(By.CSS_SELECTOR, '#links-table tbody tr[data-entity="gcs1"]')}

    links = wait_for(lambda: (x := own_links()) and all(" rmax1ob1 " in t for t in x.values()) and x, 10,
                     "both console links with their neighbour rmax1ob1")
    assert set(links) == {"gcsPortDatalink1", "gcsPortDatalink2"}
    # ... and every other entity's links with their counters, read over the bus (LIST links).
    remote = wait_for(lambda: (x := browser.execute_script(
        "return Array.from(document.querySelectorAll('#links-table tbody tr')).map(r => r.dataset.entity + ':' + "
        "r.dataset.link)")) and {"fcs20:onboardPortDatalink1", "rmax1ob2:onboard2PortIPC",
                                 "rmax1ob1:onboardPortRelay"} <= set(x) and x, 10, "the entities' link tables")
    assert sum(1 for x in remote if x.startswith("rmax1ob1:")) == 5  # its four Table 2 links and the spare
    fcs = row_text(browser, '#fleet-table tr[data-entity="fcs20"]')
    assert "rmax1ob1" in fcs and " 2 " in f" {fcs} ", fcs  # two hops, via rmax1ob1
    wait_for(lambda: "N " in browser.find_element(By.CSS_SELECTOR, '#fleet-table tr[data-entity="rmax1ob1"]').text,
             10, "rmax1ob1's position (navFilterState.positionNed read over the bus)")
    browser.save_screenshot(str(shots / "fleet.png"))

    browser.execute_script("window.__sameLoad = 42;")
    table2.start_vehicle("rmax2")
    late = wait_for(lambda: (r := fleet_rows(browser)).get("rmax2", {}).get("state") == "alive" and r["rmax2"],
                    20, "the vehicle started mid-test, learned by routing")
    assert late["origin"] == "learned", late
    assert browser.execute_script("return window.__sameLoad;") == 42  # no reload
    wait_for(lambda: "N " in browser.find_element(By.CSS_SELECTOR, '#fleet-table tr[data-entity="rmax2"]').text,
             10, "rmax2's position")
    browser.save_screenshot(str(shots / "fleet_learned.png"))


def test_admin_row_added_in_page_becomes_active_and_flows_at_its_rate(table2: ConsoleTable2, browser: Any,
                                                                       shots: Path) -> None:
    load(browser, table2.url)
    # Cancel sends nothing.
    admin_add(browser, "gpsOut", "rmax1ob1", "gcs1", 100, "publication")
    wait_for(lambda: browser.find_element(By.ID, "confirm").is_displayed(), 5, "the confirm dialog")
    browser.find_element(By.ID, "confirm-no").click()
    time.sleep(0.6)
    assert admin_status(browser, "gpsOut", "rmax1ob1") is None

    admin_add(browser, "gpsOut", "rmax1ob1", "gcs1", 100, "publication")
    msg = confirm(browser, "add publication gpsOut rmax1ob1 -> gcs1 every 100 ms")
    assert "added and activated" in msg, msg
    row = wait_for(lambda: (s := admin_status(browser, "gpsOut", "rmax1ob1")) and s["status"] == "active" and s,
                   10, "the new row active")
    browser.save_screenshot(str(shots / "admin.png"))
    # Measured where it is received (gcs1, the console's node): 10 Hz.
    tab(browser, "plots")
    time.sleep(3.5)
    rate = wait_for(lambda: flow_rate(browser, "gpsOut@rmax1ob1"), 5, "gpsOut's rate at gcs1")
    assert 8.5 <= rate <= 11.5, rate

    # A lasting period change through the confirm step: 100 ms -> 50 ms.
    tab(browser, "admin")
    click(browser, f'//tr[@data-row="{row["row"]}"]//button[text()="Period…"]')
    answer_prompt(browser, "50")
    assert "lasting" in confirm(browser, "from 100 ms to 50 ms")
    wait_for(lambda: admin_status(browser, "gpsOut", "rmax1ob1")["period"] == "50", 5, "period 50 in the table")
    tab(browser, "plots")
    time.sleep(5.5)
    rate = flow_rate(browser, "gpsOut@rmax1ob1")
    assert rate is not None and 17.0 <= rate <= 23.0, rate

    # Deactivate, then activate again, each through the confirm step: the flow stops, then comes back.
    tab(browser, "admin")
    click(browser, f'//tr[@data-row="{row["row"]}"]//button[text()="Deactivate…"]')
    assert "deactivated" in confirm(browser, f"deactivate administration row {row['row']} (gpsOut")
    wait_for(lambda: admin_status(browser, "gpsOut", "rmax1ob1")["status"] != "active", 10, "the row deactivated")
    tab(browser, "plots")
    wait_for(lambda: (r := flow_rate(browser, "gpsOut@rmax1ob1")) is None or r < 5.0, 15, "gpsOut stopped")
    tab(browser, "admin")
    click(browser, f'//tr[@data-row="{row["row"]}"]//button[text()="Activate…"]')
    assert "activated" in confirm(browser, f"activate administration row {row['row']} (gpsOut")
    wait_for(lambda: admin_status(browser, "gpsOut", "rmax1ob1")["status"] == "active", 10, "the row active again")
    tab(browser, "plots")
    wait_for(lambda: (r := flow_rate(browser, "gpsOut@rmax1ob1")) is not None and r > 15.0, 15, "gpsOut back at 20 Hz")


def test_field_written_in_browser_is_read_back_over_the_bus(table2: ConsoleTable2, browser: Any,
                                                              shots: Path) -> None:
    load(browser, table2.url)
    tab(browser, "vars")
    wait_for(lambda: "fcs20" in [o.get_attribute("value") for o in
                                 browser.find_elements(By.CSS_SELECTOR, "#var-entity option")], 10, "fcs20 listed")
    Select(browser.find_element(By.ID, "var-entity")).select_by_value("fcs20")
    browser.find_element(By.ID, "var-dir").send_keys("fcsSet")
    browser.find_element(By.ID, "var-open").click()
    cell = '#var-table tr[data-field="fcsSet.mode"]'
    wait_for(lambda: browser.find_elements(By.CSS_SELECTOR, cell), 10, "fcsSet's fields")
    click(browser, '//tr[@data-field="fcsSet.mode"]//button')
    answer_prompt(browser, "3")
    msg = confirm(browser, "write fcsSet.mode = 3 into fcs20")
    assert msg.endswith("written; read back over the bus: 3"), msg
    wait_for(lambda: browser.find_element(By.CSS_SELECTOR, f"{cell} td.value").text == "3", 5, "the live value 3")
    browser.save_screenshot(str(shots / "variables.png"))
    # fcs20's own process says so too (its stdin `dump`, not the bus).
    proc = table2.hitl.group["backup"]
    mark = proc.mark()
    proc.send("dump fcsSet")
    ev = proc.wait_event("dump", 5.0, since=mark)
    from uavbus import Catalogue

    cat = Catalogue.load(table2.hitl.catalogue_path)
    assert int(cat.decode("fcsSet", bytes.fromhex(ev["packed"]))["mode"]) == 3, ev

    # The whole directory as JSON (live refresh off, so the text edited is the text sent).
    browser.find_element(By.ID, "var-live").click()
    browser.execute_script("const t = document.getElementById('var-json'); const v = JSON.parse(t.value); "
                           "v.mode = 4; v.switches.logLevel = 5; t.value = JSON.stringify(v);")
    click(browser, '//button[@id="var-write-all"]')
    msg = confirm(browser, "write fcsSet = {")
    assert "fcsSet written; read back over the bus: {" in msg, msg
    back = json.loads(msg.split("read back over the bus: ", 1)[1])
    assert back["mode"] == 4 and back["switches"]["logLevel"] == 5, back
    mark = proc.mark()
    proc.send("dump fcsSet")
    ev = proc.wait_event("dump", 5.0, since=mark)
    mine = cat.decode("fcsSet", bytes.fromhex(ev["packed"]))
    assert int(mine["mode"]) == 4 and int(mine["switches"]["logLevel"]) == 5, ev


def test_plot_of_imu_p_receives_points_at_50_hz(table2: ConsoleTable2, browser: Any, shots: Path,
                                                downloads: Path) -> None:
    load(browser, table2.url)
    admin_add(browser, "imuOut", "fcs20", "gcs1", 20, "subscription")
    confirm(browser, "add subscription imuOut fcs20 -> gcs1 every 20 ms")
    wait_for(lambda: (s := admin_status(browser, "imuOut", "fcs20")) and s["status"] == "active", 10,
             "the imuOut subscription active")
    tab(browser, "plots")
    sel = wait_for(lambda: browser.find_element(By.CSS_SELECTOR, 'select[data-key="imuOut@fcs20"]'), 10, "imuOut's row")
    Select(sel).select_by_value("p")
    click(browser, '//tr[@data-flow="imuOut@fcs20"]//button[text()="Plot"]')
    key = "imuOut@fcs20:p"
    points = "return state.plot.series.get(arguments[0]).points.map(p => p[0]);"
    wait_for(lambda: len(browser.execute_script(points, key)) > 50, 10, "points of imuOut.p")
    time.sleep(3.0)
    ts = browser.execute_script(points, key)
    recent = [t for t in ts if t >= ts[-1] - 2.0]
    assert 85 <= len(recent) <= 115, f"{len(recent)} points in the last 2 s (50 Hz: 100)"
    legend = browser.find_element(By.CSS_SELECTOR, f'#plot-legend span[data-series="{key}"]')
    assert legend.get_attribute("data-unit") == "rad/s" and "[rad/s]" in legend.text  # imu.h's comment
    assert int(legend.get_attribute("data-points")) == len(ts) or int(legend.get_attribute("data-points")) > 100
    # Several at once: imuOut.q beside it, each its own series with its own points.
    Select(browser.find_element(By.CSS_SELECTOR, 'select[data-key="imuOut@fcs20"]')).select_by_value("q")
    click(browser, '//tr[@data-flow="imuOut@fcs20"]//button[text()="Plot"]')
    wait_for(lambda: len(browser.execute_script(points, "imuOut@fcs20:q")) > 20, 10, "points of imuOut.q")
    assert browser.execute_script("return Array.from(state.plot.series.keys()).sort();") == [key, "imuOut@fcs20:q"]
    browser.save_screenshot(str(shots / "plot.png"))
    # Pause holds the plot still; the CSV export writes what it shows.
    browser.find_element(By.ID, "plot-pause").click()
    n = len(browser.execute_script(points, key))
    time.sleep(0.8)
    assert len(browser.execute_script(points, key)) == n
    browser.find_element(By.ID, "plot-csv").click()
    path = downloads / "uavbus-plot.csv"
    wait_for(path.exists, 5, "the exported CSV")
    with path.open() as fh:
        every = list(csv.DictReader(fh))
    rows = [r for r in every if r["series"] == key]
    assert {r["series"] for r in every} == {key, "imuOut@fcs20:q"}
    assert len(rows) == n and all(abs(float(r["value"])) < 10 and r["unit"] == "rad/s" for r in rows)
    # The variable browser shows the unit and the description beside the live value.
    tab(browser, "vars")
    Select(browser.find_element(By.ID, "var-entity")).select_by_value("fcs20")
    field = browser.find_element(By.ID, "var-dir")
    field.clear()
    field.send_keys("imuOut")
    browser.find_element(By.ID, "var-open").click()
    unit, text = wait_for(lambda: browser.execute_script(
        "const tr = document.querySelector('#var-table tr[data-field=\"imuOut.p\"]');"
        "return tr && [tr.querySelector('td.unit').textContent, tr.textContent];"), 10, "imuOut.p")
    assert unit == "rad/s" and "roll rate" in text, text
    browser.save_screenshot(str(shots / "variables_units.png"))

    # fcs20's tables over the bus: its publish/subscribe table has the flow asked above, its entity table
    # Table 2's entities, its administration table is there (empty: fcs20 administers nothing).
    def table(name: str, want: Any) -> list[str]:
        browser.find_element(By.CSS_SELECTOR, f'.var-table[data-table="{name}"]').click()
        return wait_for(lambda: browser.find_element(By.ID, "var-title").text.startswith(f"fcs20: {name} (read")
                        and want(rows := [tr.text for tr in browser.find_elements(By.CSS_SELECTOR, "#var-table tbody tr")])
                        and (rows,), 10, f"fcs20's {name} table")[0]
    table("pubsub", lambda rows: any("imuOut" in r and "gcs1" in r and " 20" in r for r in rows))
    entities = table("entities", lambda rows: all(any(n in r for r in rows) for n in TABLE2))
    assert len(entities) >= 4, entities
    table("admin", lambda rows: rows == [])

    # Discovery: what fcs20 offers (each catalogued directory hosted or not, its flows now).
    browser.find_element(By.ID, "var-offer").click()
    offered = wait_for(lambda: (rows := browser.execute_script(
        "return Object.fromEntries(Array.from(document.querySelectorAll('#var-table tr[data-dir]')).map("
        "tr => [tr.dataset.dir, Array.from(tr.children).map(td => td.textContent)]))")) and "fcsSet" in rows and rows,
        30, "fcs20's offer")
    assert offered["fcsSet"][3] == "yes" and offered["imuOut"][3] == "yes", offered
    assert "publication to gcs1 every 20 ms" in offered["imuOut"][4], offered["imuOut"]  # the row added above
    from uavbus import Catalogue

    # Every catalogued directory answered (uavbus_node hosts them all; a probe with no answer would show "?").
    assert set(offered) == {inst.name for inst in Catalogue.load(table2.hitl.catalogue_path)}
    assert all(r[3] in ("yes", "no") for r in offered.values()), [k for k, r in offered.items() if r[3] not in ("yes", "no")]
    assert not browser.find_element(By.ID, "var-whole").is_displayed()  # no directory to write as a whole
    browser.save_screenshot(str(shots / "variables_offer.png"))


@pytest.fixture(scope="module")
def refused_table2(program: Path, tmp_path_factory: pytest.TempPathFactory) -> Any:
    # Only rmax1ob2 administers: gcs1's requests are refused by the targets with their reason.
    sec = {"administrators": ["rmax1ob2"], "write": {"fcs20": [{"from": "gcs1", "content": "fcsSet"}]}}
    with ConsoleTable2(tmp_path_factory.mktemp("refused"), program=program, routing=False, security=sec) as t:
        yield t


def test_refusal_not_an_administrator_is_shown_with_its_reason(refused_table2: ConsoleTable2, browser: Any,
                                                               shots: Path) -> None:
    load(browser, refused_table2.url)
    # Data for another entity is the administrators' business (a non-administrator may ask for data to itself).
    admin_add(browser, "gpsOut", "rmax1ob1", "fcs20", 100, "publication")
    confirm(browser, "add publication gpsOut rmax1ob1 -> fcs20")
    row = wait_for(lambda: (s := admin_status(browser, "gpsOut", "rmax1ob1")) and s["status"] == "failed" and s,
                   10, f"the row refused ({admin_status(browser, 'gpsOut', 'rmax1ob1')})")
    assert row["reason"] == "not_authorized", row
    assert "not one of them" in browser.find_element(By.ID, "admin-policy").text
    browser.save_screenshot(str(shots / "admin_refused.png"))
    tab(browser, "vars")
    wait_for(lambda: "fcs20" in [o.get_attribute("value") for o in
                                 browser.find_elements(By.CSS_SELECTOR, "#var-entity option")], 10, "fcs20 listed")
    Select(browser.find_element(By.ID, "var-entity")).select_by_value("fcs20")
    browser.find_element(By.CSS_SELECTOR, '.var-table[data-table="links"]').click()
    title = wait_for(lambda: (t := browser.find_element(By.ID, "var-title")).get_attribute("data-reason") and t, 10,
                     "the refusal of fcs20's link table")
    assert title.get_attribute("data-reason") == "not_authorized" and "refused (not_authorized)" in title.text
    browser.save_screenshot(str(shots / "variables_refused.png"))


@pytest.mark.parametrize("gcs_roles", ["admin", "observer"])
def test_the_console_writes_as_its_identity_and_the_certificate_decides(program: Path, browser: Any, shots: Path,
                                                                        tmp_path: Path, gcs_roles: str) -> None:
    """Signed Table 2 with an identity per entity: the console's request leaves as gcs1, signed with gcs1's
    key, and rmax1ob1 judges it on gcs1's certificate. Same keys, names and configuration: served when the
    certificate says admin, refused with its reason when it says observer (the console adds no authority)."""
    roles = {"gcs1": gcs_roles, "rmax1ob1": "vehicle,relay", "rmax1ob2": "vehicle", "fcs20": "vehicle"}
    sec = identity_security(tmp_path / "ids", roles)
    with ConsoleTable2(tmp_path / "ids", program=program, routing=False, security=sec) as t:
        load(browser, t.url)
        admin_add(browser, "gpsOut", "rmax1ob1", "rmax1ob2", 100, "publication")  # data to a third party
        confirm(browser, "add publication gpsOut rmax1ob1 -> rmax1ob2")
        want = "active" if gcs_roles == "admin" else "failed"
        row = wait_for(lambda: (s := admin_status(browser, "gpsOut", "rmax1ob1")) and s["status"] == want and s,
                       10, f"the row {want} ({admin_status(browser, 'gpsOut', 'rmax1ob1')})")
        policy = browser.find_element(By.ID, "admin-policy")
        assert policy.get_attribute("data-roles") == gcs_roles, policy.text  # gcs1's own certificate, read here
        assert policy.text.startswith(f"gcs1's certificate says {gcs_roles}: ")
        assert ("targets let it administer" in policy.text) == (gcs_roles == "admin"), policy.text
        if gcs_roles == "observer":
            assert row["reason"] == "not_authorized", row
            browser.save_screenshot(str(shots / "admin_refused_by_certificate.png"))
        # rmax1ob1's own counters: the refusal is its policy's, on the certificate (a frame it could not verify
        # would be dropped before the policy, and the row would stay pending, not failed).
        stats = t.hitl.child_stats("primary")
        drops = stats["node"]["drops"]
        if gcs_roles == "observer":
            assert drops["not_authorized"] >= 1, drops
        else:
            assert drops.get("not_authorized", 0) == 0, drops
        assert stats["identity"]["lookups"] >= 1 and stats["identity"]["lookups_refused"] == 0, stats["identity"]
