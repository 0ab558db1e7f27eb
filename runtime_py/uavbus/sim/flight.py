"""The simulated vehicles' flight model, from Python: the C runtime's ub_motion (the one uavbus_node flies,
programs/node/node_motion.c), so a vehicle moves the same way whichever process hosts it.

`FlightModel(text)` parses the text form ("orbit:r=150,v=12", "waypoints:v=15,pts=0/0;900/0",
"static:n=-50"); `sample(t_s)` gives position and motion at t seconds after the path's start.
`VehicleDirectories` writes samples into a Python node's gpsOut, imuOut and navFilterState the way
node_motion.c writes them into the C structs (the mapping is per language; the kinematics are one).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

__all__ = ["FlightModel", "Sample", "VehicleDirectories", "PRODUCED"]

PRODUCED = ("gpsOut", "imuOut", "navFilterState")  # what a simulated vehicle produces (uavbus_node --produce)


@dataclass(frozen=True)
class Sample:
    north_m: float
    east_m: float
    up_m: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    vel_ned: tuple[float, float, float]
    heading_rad: float
    rates: tuple[float, float, float]
    specific_force: tuple[float, float, float]
    attitude: tuple[float, float, float, float]

    def distance(self, other: Sample) -> float:
        """Horizontal distance in metres (same datum)."""
        return math.hypot(self.north_m - other.north_m, self.east_m - other.east_m)


class FlightModel:
    def __init__(self, text: str) -> None:
        from uavbus._bindings import ub_motion

        self.text = text
        self._c = ub_motion.ub_motion_parse(text)  # InvalidArgumentError with the C parser's message
        self._state: Any = None

    def sample(self, t_s: float) -> Sample:
        from uavbus._bindings import ub_motion

        s = self._state = ub_motion.ub_motion_sample(self._c, t_s, self._state)
        return Sample(s.north_m, s.east_m, s.up_m, s.lat_deg, s.lon_deg, s.alt_msl_m, tuple(s.vel_ned),
                      s.heading_rad, tuple(s.rates), tuple(s.specific_force), tuple(s.attitude))


def _stamp() -> dict[str, int]:
    now = time.monotonic()  # CLOCK_MONOTONIC, as uavbus_node stamps its timeTags
    return {"seconds": int(now), "microseconds": int((now % 1.0) * 1e6)}


class VehicleDirectories:
    """gpsOut / imuOut / navFilterState of a Python node, animated from a FlightModel (t = seconds on the
    model's clock). Counters (solutionCount, sampleCount, updateCount) count updates, as in C."""

    def __init__(self, node: Any, model: FlightModel) -> None:
        self.model = model
        self.gps, self.imu, self.nav = (node.bind(name) for name in PRODUCED)
        self.updates = 0

    def update(self, t_s: float, dt_s: float) -> Sample:
        s = self.model.sample(t_s)
        stamp = _stamp()
        self.updates += 1
        self.gps.update(time=stamp, latitudeDeg=s.lat_deg, longitudeDeg=s.lon_deg, altitudeMsl=s.alt_msl_m,
                        velocityNed=dict(zip("xyz", s.vel_ned)), horizontalAccuracy=1.5, verticalAccuracy=3.0,
                        pdop=1.4, satellitesUsed=9, solutionCount=self.updates)
        p, q, r = s.rates
        self.imu.update(time=stamp, p=p, q=q, r=r, specificForce=dict(zip("xyz", s.specific_force)),
                        deltaVelocity=dict(zip("xyz", (f * dt_s for f in s.specific_force))),
                        deltaAngle=dict(zip("xyz", (w * dt_s for w in s.rates))), temperatureC=35.0,
                        sampleCount=self.updates)
        self.nav.update(time=stamp, positionNed={"x": s.north_m, "y": s.east_m, "z": -s.up_m},
                        velocityNed=dict(zip("xyz", s.vel_ned)),
                        attitude=dict(zip(("q0", "q1", "q2", "q3"), s.attitude)), updateCount=self.updates,
                        aligned=1)
        return s
