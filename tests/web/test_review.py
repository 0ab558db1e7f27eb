"""Log review in the console (`uavbus web --log FILE`): a log recorded by a Python GCS is opened, its flows
listed, a field's points returned for a time window, positions at a chosen time; and the page in Chromium
with its time slider."""

from __future__ import annotations

import asyncio
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

from uavbus import Catalogue, MemLink, Node
from uavbus.sim.build import REPO
from uavbus.sim.hitl import catalogue_for
from uavbus.web.review import LogReview
from uavbus.web.server import make_app

from web_testutil import wait_for

TABLE2 = REPO / "examples" / "configs" / "table2.json"
STEPS, STEP_MS = 150, 20  # 3 s of flight at 50 Hz
pytestmark = pytest.mark.timeout(60)


class Clock:
    def __init__(self) -> None:
        self.t = 1000

    def __call__(self) -> int:
        return self.t


@pytest.fixture(scope="module")
def flight_log(program: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """rmax1ob1 flies north at 10 m/s and sends imuOut (p = sin) and navFilterState to gcs1, which records."""
    cat = Catalogue.load(catalogue_for(program))
    clock = Clock()
    gcs = Node(cat, config=TABLE2, node="gcs", clock=clock)
    air = Node(cat, config=TABLE2, node="primary", clock=clock)
    MemLink(air, "onboardPortDatalink1", gcs, "gcsPortDatalink1")
    for c in ("imuOut", "navFilterState"):
        gcs.bind(c)
    imu, nav = air.publisher("rmax1ob1", "imuOut", "gcs1"), air.publisher("rmax1ob1", "navFilterState", "gcs1")
    path = tmp_path_factory.mktemp("review") / "gcs1.ublog"
    gcs.record(path)
    for k in range(STEPS):
        t = k * STEP_MS / 1000.0
        imu.directory.p = math.sin(t)
        imu.send()
        if k % 5 == 0:
            nav.directory.positionNed.x = 10.0 * t
            nav.directory.positionNed.y = 5.0
            nav.send()
        clock.t += STEP_MS
        air.poll(0)
        gcs.poll(0)
    gcs.stop_recording()
    gcs.close()
    air.close()
    return path


def test_review_lists_flows_points_and_positions(flight_log: Path) -> None:
    r = LogReview(flight_log)
    info = r.info()
    flows = {(f["content"], f["source"]): f for f in info["flows"]}
    imu = flows[("imuOut", "rmax1ob1")]
    assert imu["messages"] == STEPS and imu["rate_hz"] == pytest.approx(50.0, rel=0.01)
    assert "p" in imu["fields"] and imu["units"]["p"] == "rad/s"
    assert flows[("navFilterState", "rmax1ob1")]["messages"] == STEPS // 5
    assert info["t1"] - info["t0"] == pytest.approx((STEPS - 1) * STEP_MS / 1000.0, abs=0.002)
    # One second of imuOut.p from the middle: 50 points, the values sent.
    mid = info["t0"] + 1.0
    pts = r.series([("imuOut", "rmax1ob1", "p")], mid, mid + 0.99)["series"]["imuOut@rmax1ob1:p"]
    assert len(pts) == 50
    assert all(v == pytest.approx(math.sin(t - info["t0"]), abs=1e-4) for t, v in pts)  # times kept to 0.1 ms
    # Where rmax1ob1 was 2 s in: the last navFilterState at or before it (sent every 100 ms).
    pos = {e["name"]: e for e in r.positions(info["t0"] + 2.0)["entities"]}
    assert pos["rmax1ob1"]["position"]["n"] == pytest.approx(20.0) and pos["rmax1ob1"]["position"]["e"] == 5.0
    assert r.positions(info["t0"] - 1.0)["entities"] == []  # before the log: nowhere yet

    async def api() -> None:
        from aiohttp.test_utils import TestClient, TestServer

        client = TestClient(TestServer(make_app(None, token=None, review=r)))
        await client.start_server()
        try:
            got = await (await client.get("/api/info")).json()
            assert got["mode"] == "review" and got["log"] == flight_log.name
            s = await (await client.get("/api/review/series", params={"k": "imuOut@rmax1ob1:p", "t0": mid,
                                                                      "t1": mid + 0.99})).json()
            assert len(s["series"]["imuOut@rmax1ob1:p"]) == 50
            assert (await client.post("/api/prepare", json={})).status in (403, 404, 405)  # nothing writes
            assert (await client.get("/api/fleet")).status == 404
        finally:
            await client.close()
    asyncio.run(api())


def test_review_page_scrubs_the_log(flight_log: Path, browser: Any, shots: Path, tmp_path: Path) -> None:
    url_file = tmp_path / "url"
    proc = subprocess.Popen([sys.executable, "-m", "uavbus.cli", "web", "--log", str(flight_log), "--http",
                             "127.0.0.1:0", "--url-file", str(url_file)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    try:
        wait_for(url_file.exists, 20, "uavbus web --log listening")
        browser.get(url_file.read_text().strip())
        wait_for(lambda: browser.find_element(By.TAG_NAME, "body").get_attribute("data-ready") == "1", 10, "page")
        assert browser.find_element(By.ID, "view-review").is_displayed()
        assert not browser.find_element(By.ID, "tab-fleet").is_displayed()  # no live views without a node
        Select(browser.find_element(By.CSS_SELECTOR, 'select[data-key="imuOut@rmax1ob1"]')).select_by_value("p")
        browser.find_element(By.XPATH, '//tr[@data-flow="imuOut@rmax1ob1"]//button').click()
        info = json.loads(browser.execute_script("return JSON.stringify(review.info)"))
        t = info["t0"] + 2.0
        browser.execute_script("const s = document.getElementById('review-t'); s.value = arguments[0];"
                               "s.dispatchEvent(new Event('input'));", t)
        wait_for(lambda: abs(float(browser.find_element(By.TAG_NAME, "body").get_attribute("data-review-t") or 0) - t)
                 < 0.06, 10, "the page at the chosen time")
        legend = wait_for(lambda: browser.find_element(By.CSS_SELECTOR,
                                                       '#review-legend span[data-series="imuOut@rmax1ob1:p"]'),
                          10, "the plot's legend")
        # The 10 s window before t = 2 s holds the first 2 s of the log: about 100 points at 50 Hz.
        assert 98 <= int(legend.get_attribute("data-points")) <= 102 and legend.get_attribute("data-unit") == "rad/s"
        browser.save_screenshot(str(shots / "review.png"))
    finally:
        proc.terminate()
        proc.wait(10)
