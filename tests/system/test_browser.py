"""Issue 16 acceptance: the variable browser over the bus against real C processes.

The paper's Table 2 (uavbus.sim.hitl): gcs1 is the Python GCS; fcs20 runs in a `uavbus_node` process
two hops away (gcs1 -> rmax1ob1 -> fcs20). Every request is an INSPECT frame answered by fcs20's C node:
directories it never bound by hand (hosted through the generated bind table), every table, a rate and a
mask changed, and a policy's refusal with its reason.
"""

from __future__ import annotations

import json

import pytest

from uavbus.errors import RefusedError
from uavbus.sim.hitl import Hitl, HitlOptions

pytestmark = pytest.mark.timeout(60)


def test_read_write_tables_rate_and_mask_two_hops(hitl_opts: HitlOptions) -> None:
    # fcs20 publishes imuOut to gcs1 every 100 ms, from its own command line (a row with no owner).
    hitl_opts.node_args = {"backup": ["--publish", "fcs20:imuOut>gcs1/100"]}
    with Hitl(hitl_opts) as h:
        assert h.topo is not None and h.topo.hops("gcs", "backup") == 2
        fcs = h.gcs.remote("fcs20")
        # airData is catalogued and defined in flightsw_data.c, but uavbus_node never binds it by hand.
        before = fcs.get("airData")
        assert set(before) >= {"staticPressurePa", "rawCounts"}
        assert fcs.set("airData.staticPressurePa", 101325.0) is True
        assert fcs.get("airData.staticPressurePa") == pytest.approx(101325.0)
        assert fcs.get("airData")["rawCounts"] == before["rawCounts"]  # a field write leaves the others
        assert fcs.set("airData.staticPressurePa", 101325.0) is False  # already so
        fcs.set("fcsSet.mode", 3)
        assert int(fcs.get("fcsSet.mode")) == 3

        tables = fcs.tables()
        names = {e["entity"]: e for e in tables["entities"]}
        assert set(names) == {"rmax1ob1", "rmax1ob2", "fcs20", "gcs1"} and names["fcs20"]["local"]
        assert names["gcs1"]["mask"] == "0x00000001"
        (link,) = tables["links"]
        assert link["link"] == "onboardPortDatalink1" and link["frames_in"] > 0 and link["frames_out"] > 0
        (row,) = [r for r in tables["pubsub"] if r["content"] == "imuOut"]
        assert row["kind"] == "publication" and row["peer"] == "gcs1" and row["period_ms"] == 100
        assert tables["admin"] == []

        # A rate: 100 ms -> 20 ms, seen in the table and in what gcs1 receives.
        h.gcs.bind("imuOut")
        assert fcs.set_period(row["row"], 20) is True
        assert [r["period_ms"] for r in fcs.table("pubsub") if r["row"] == row["row"]] == [20]
        t0 = h.mark("fast")
        h.run_for(1.0)
        assert h.meter("imuOut", "fcs20").rate_hz(t0, t0 + 1.0) > 30.0  # 50 Hz requested, 10 Hz before

        # A mask: fcs20 -> rmax1ob2 pinned to 0x00000001 (it was so by configuration: unchanged, pinned).
        assert fcs.set_mask("rmax1ob2", "0x00000001") is False
        entities = {e["entity"]: e for e in fcs.table("entities")}
        assert entities["rmax1ob2"]["pinned"] and entities["rmax1ob2"]["mask"] == "0x00000001"
        with pytest.raises(RefusedError) as refused:
            fcs.set_mask("nobody", 1)
        assert refused.value.reason == "no_such_row"
        assert h.gcs.counters()["drops"]["bad_payload"] == 0


def test_policy_refusal_shows_its_reason(browser_policy_opts: HitlOptions) -> None:
    hitl_opts = browser_policy_opts  # only rmax1ob2 administers; gcs1 may write fcsSet into fcs20; reads open
    with Hitl(hitl_opts) as h:
        fcs = h.gcs.remote("fcs20")
        assert "time" in fcs.get("gpsOutBackup")  # reads are open
        assert fcs.set("fcsSet.mode", 2) in (True, False)  # the write rule grants it
        with pytest.raises(RefusedError) as refused:
            fcs.set("airData.staticPressurePa", 1.0)
        assert refused.value.reason == "not_authorized" and "not_authorized" in str(refused.value)
        with pytest.raises(RefusedError) as refused:
            fcs.table("links")  # tables are the administrators'
        assert refused.value.reason == "not_authorized"


def test_cli_get_and_set_against_c_process(hitl_opts: HitlOptions) -> None:
    import subprocess
    import sys

    hitl_opts.start_gcs = False  # the CLI is the GCS: it hosts gcs1 on its UDP datalink
    with Hitl(hitl_opts) as h:
        assert h.topo is not None
        spec = h.topo.specs("gcs")["gcsPortDatalink1"]
        common = ["--config", str(hitl_opts.config), "--node", "gcs", "--catalogue", str(h.catalogue_path),
                  "--port", f"gcsPortDatalink1={spec}"]

        def cli(*args: str) -> subprocess.CompletedProcess:
            return subprocess.run([sys.executable, "-m", "uavbus.cli", *args, *common], capture_output=True,
                                  text=True, timeout=30)

        r = cli("set", "fcs20", "airData.outsideAirTempC", "21.5")
        assert r.returncode == 0 and json.loads(r.stdout) == {"changed": True}, r.stderr
        r = cli("get", "fcs20", "airData.outsideAirTempC")
        assert r.returncode == 0 and json.loads(r.stdout) == pytest.approx(21.5), r.stderr
        r = cli("get", "fcs20", "airData.noSuchField")
        assert r.returncode == 2 or r.returncode == 3 or r.returncode == 1, r
        assert r.stderr.count("\n") == 1 and "noSuchField" in r.stderr
