"""The console's browser tests (issue 27): Debian's Chromium, headless, driven by Selenium through
chromium-driver, against Table 2 running as processes (uavbus.web.table2) with `uavbus web` as gcs1.

Screenshots of every view go to $UAVBUS_WEB_SHOTS (default build/web-shots/), to be looked at. A missing
Chromium or driver fails the tests with what to install (make setup installs both): a skipped acceptance
test would look green.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from uavbus.sim.build import REPO, NodeProgramMissing, node_program

CHROMIUM = os.environ.get("UAVBUS_CHROMIUM", "/usr/bin/chromium")
DRIVER = os.environ.get("UAVBUS_CHROMEDRIVER", shutil.which("chromedriver") or "/usr/bin/chromedriver")


@pytest.fixture(scope="session")
def program() -> Path:
    try:
        return node_program(build=False)
    except NodeProgramMissing as e:
        pytest.fail(f"uavbus_node not available: {e}")


@pytest.fixture(scope="session")
def shots() -> Path:
    d = Path(os.environ.get("UAVBUS_WEB_SHOTS", REPO / "build" / "web-shots"))
    d.mkdir(parents=True, exist_ok=True)
    return d


@pytest.fixture(scope="session")
def downloads(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("downloads")


@pytest.fixture(scope="session")
def browser(downloads: Path) -> Iterator[Any]:
    if not (Path(CHROMIUM).exists() and Path(DRIVER).exists()):
        pytest.fail(f"{CHROMIUM} or {DRIVER} missing: apt-get install chromium chromium-driver (make setup does)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,1000",
              "--no-first-run", "--disable-extensions"):
        opts.add_argument(a)
    opts.binary_location = CHROMIUM
    opts.add_experimental_option("prefs", {"download.default_directory": str(downloads),
                                           "download.prompt_for_download": False})
    driver = webdriver.Chrome(options=opts, service=Service(DRIVER))
    driver.set_page_load_timeout(20)
    try:
        yield driver
    finally:
        driver.quit()
