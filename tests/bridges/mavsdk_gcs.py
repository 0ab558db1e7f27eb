"""A MAVSDK ground station (the `mavsdk` PyPI package: MAVSDK's C library, nobody here wrote it) on the
front door, run in its own process so that a MAVSDK thread can never hang pytest.

    python mavsdk_gcs.py --url udpout://127.0.0.1:PORT --vehicles 3 --arm 2 --param 2:TEST_P05=42.5 [--mission 3:5]

Waits for the vehicles (system ids), reads each one's attitude, arms one, sets and reads back one
parameter of one vehicle; with --mission SYSID:N uploads N waypoints to that vehicle with MAVSDK's mission
plugin and downloads them again; with --rate SYSID:HZ asks that vehicle's attitude at HZ. One JSON object on stdout: {"systems": [...], "attitude": {sysid: roll_deg},
"arm": "ok" | error, "param": value | error, "mission": {"up": [[lat, lon, alt]...], "down": [...]} | error}.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from mavsdk.component_type import ComponentType
from mavsdk.mavsdk import Configuration, Mavsdk
from mavsdk.plugins.action import Action
from mavsdk.plugins.mission import Mission, MissionItem, MissionPlan
from mavsdk.plugins.param import Param
from mavsdk.plugins.telemetry import Telemetry


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--vehicles", type=int, required=True)
    ap.add_argument("--arm", type=int, required=True)
    ap.add_argument("--param", required=True, help="SYSID:NAME=VALUE")
    ap.add_argument("--mission", help="SYSID:N waypoints to upload and download")
    ap.add_argument("--rate", help="SYSID:HZ: the attitude rate asked of that vehicle (MAVSDK's set_rate_attitude_euler)")
    ap.add_argument("--timeout", type=float, default=25.0)
    args = ap.parse_args()
    out: dict = {}
    m = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    m.add_any_connection(args.url)
    end = time.monotonic() + args.timeout
    systems: dict[int, object] = {}
    while time.monotonic() < end and len(systems) < args.vehicles:
        for s in m.get_systems():
            sid = s.get_system_id()
            if sid not in systems and s.has_autopilot():
                systems[sid] = s
        time.sleep(0.2)
    out["systems"] = sorted(systems)
    out["attitude"] = {}
    for sid, s in systems.items():
        tel = Telemetry(s)
        roll = float("nan")
        while time.monotonic() < end and math.isnan(roll):
            roll = tel.attitude_euler().roll_deg
            if math.isnan(roll) or roll == 0.0:
                roll = float("nan")
                time.sleep(0.1)
        out["attitude"][str(sid)] = None if math.isnan(roll) else roll
    target = systems.get(args.arm)
    try:
        Action(target).arm()
        out["arm"] = "ok"
    except Exception as e:  # noqa: BLE001 (reported to the test, which asserts on it)
        out["arm"] = f"{type(e).__name__}: {e}"
    psys, assignment = args.param.split(":", 1)
    name, value = assignment.split("=", 1)
    try:
        p = Param(systems[int(psys)])
        p.set_param_float(name, float(value))
        out["param"] = p.get_param_float(name)
    except Exception as e:  # noqa: BLE001
        out["param"] = f"{type(e).__name__}: {e}"
    if args.rate:
        rsys, hz = args.rate.split(":")
        try:
            Telemetry(systems[int(rsys)]).set_rate_attitude_euler(float(hz))
            out["rate"] = "ok"
        except Exception as e:  # noqa: BLE001
            out["rate"] = f"{type(e).__name__}: {e}"
    if args.mission:
        msys, n = (int(x) for x in args.mission.split(":"))
        nan = float("nan")
        up = [(47.3977420 + 0.0001 * i, 8.5455940 + 0.0001 * i, 20.0 + i) for i in range(n)]
        try:
            mission = Mission(systems[msys])
            items = [MissionItem(lat, lon, alt, 5.0, True, nan, nan, MissionItem.CameraAction.NONE, nan, nan, 1.0, nan, nan,
                                 MissionItem.VehicleAction.NONE) for lat, lon, alt in up]
            mission.upload_mission(MissionPlan(items))
            down = mission.download_mission().mission_items
            out["mission"] = {"up": up, "down": [(i.latitude_deg, i.longitude_deg, i.relative_altitude_m) for i in down]}
        except Exception as e:  # noqa: BLE001
            out["mission"] = f"{type(e).__name__}: {e}"
    sys.stdout.write(json.dumps(out) + "\n")
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
