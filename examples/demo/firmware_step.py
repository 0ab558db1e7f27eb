"""`make demo`, firmware step (issue 25): hardware in the loop for real.

The flight-controller firmware (examples/mcu, Cortex-M4, bare metal) boots in QEMU's mps2-an386 board and
takes fcs20's place in the paper's Table 2 over its emulated UART: rmax1ob1's onboardPortRelay opens the
board's pty directly (no relay in between); rmax1ob1 and rmax1ob2 are `uavbus_node` processes and gcs1 the
Python GCS, as in the HITL part. Table 2 is unsigned here: the firmware is built without security (no
libsodium on the target; docs/security.md). Each is a check:
 - gcs1's administration table subscribes it to the board's imuOut two hops away at 50 Hz (+-10 %);
 - gcs1 reads one of the board's directories remotely (gpsOut, the flight model's position);
 - gcs1 changes the rate (20 -> 40 ms, on the board's row and on its own administration row) and receives
   about 25 Hz;
 - gcs1 writes the board's gyro bias and the next imuOut shows it;
 - the firmware fits 128 KiB flash / 64 KiB RAM, measured from the ELF, with the capacities the ELF records
   (16 entities, 4 links, 32 rows; the summary states all three).

Returns the `"firmware"` section of demo-out/summary.json and adds the board's imuOut row to the summary.

    from firmware_step import firmware_part
    extra["firmware"] = firmware_part(args.program, rows, check, say, short=args.short)
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

from uavbus.sim.hitl import Hitl, HitlOptions
from uavbus.sim.metrics import StreamMeter, SummaryRow
from uavbus.sim.qemu import FirmwareMissing, QemuBoard, firmware_capacities, firmware_elf, firmware_size, qemu_missing

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "examples" / "configs" / "table2.json"
IMU_MS, SLOWER_MS = 20, 40
RATE_TOLERANCE, CHANGED_TOLERANCE = 0.10, 0.15

Check = Callable[[str, bool, str], bool]


def _rate_row(h: Hitl, t0: float, t1: float, hz: float) -> SummaryRow:
    # The board stamps timeTags with its own time since power-up: no data age against the host clock.
    m = StreamMeter("imuOut", "fcs20 (QEMU)", "gcs1")
    for t in h.meter("imuOut", "fcs20").window(t0, t1):
        m.add(t)
    return SummaryRow.from_meter(m, hops=h.topo.hops("backup", "gcs") if h.topo else 2, requested_hz=hz,
                                 t0=t0, t1=t1)


def firmware_part(program: Path, rows: list[SummaryRow], check: Check, say: Callable[[str], None], *,
                  short: bool = False) -> dict[str, Any]:
    say("\n== Hardware in the loop: the firmware boots in QEMU (mps2-an386, Cortex-M4) and is fcs20 in Table 2")
    why = qemu_missing()
    if why:
        check("firmware: boots in QEMU", False, why)
        return {"skipped": why}
    try:
        elf = firmware_elf(build=True)
    except FirmwareMissing as e:
        check("firmware: built", False, str(e))
        return {"error": str(e)}
    size = firmware_size(elf)
    caps = firmware_capacities(elf)
    out: dict[str, Any] = {"elf": str(elf.relative_to(REPO)) if elf.is_relative_to(REPO) else str(elf),
                           "flash_bytes": size.flash, "ram_bytes": size.ram, "capacities": caps,
                           "machine": "mps2-an386"}
    check("firmware: fits a flight controller", size.fits(),
          f"{size}, with {caps['entities']} entities, {caps['node_links']} links, {caps['pubsub_rows']} rows")
    measure_s = 1.5 if short else 3.0
    hops: list[int] = []
    with QemuBoard(elf) as board:
        say(f"  board: {board!r}, {size}")
        opts = HitlOptions(program=program, config=CONFIG, stats_ms=500,
                           external={"backup": {"onboardPortDatalink1": board.pty}})
        with Hitl(opts) as h:
            h.on_message = lambda msg: hops.append(msg.hops) if msg.source == "fcs20" else None
            row = h.add_row("subscription", "imuOut", "fcs20", "gcs1", IMU_MS)
            try:
                h.wait_status(row, "active", 10.0)   # the board's answer, through rmax1ob1
                check("firmware: admin row active: imuOut fcs20 (QEMU) -> gcs1", True, "status active")
            except TimeoutError as e:
                check("firmware: admin row active: imuOut fcs20 (QEMU) -> gcs1", False, str(e))
                return out
            h.run_for(0.5)
            t0 = h.mark("firmware: measure")
            h.run_for(measure_s)
            t1 = h.mark("firmware: read and change")
            r = _rate_row(h, t0, t1, 1000 / IMU_MS)
            rows.append(r)
            check("firmware: rate: imuOut fcs20 (QEMU) -> gcs1", r.rate_ok(RATE_TOLERANCE),
                  f"{r.achieved_hz:.2f} Hz for {r.requested_hz:g} Hz over {h.topo.hops('backup', 'gcs')} hops "
                  f"(tolerance {RATE_TOLERANCE:.0%})")
            check("firmware: hops: imuOut fcs20 (QEMU) -> gcs1", bool(hops) and set(hops) == {2},
                  f"hops seen {sorted(set(hops))} (gcs1 - rmax1ob1 - UART - board)")

            fcs = h.gcs.remote("fcs20", timeout=5.0)
            t = time.perf_counter()
            gps = fcs.get("gpsOut")
            rtt_ms = (time.perf_counter() - t) * 1000.0
            out["read"] = {"content": "gpsOut", "rtt_ms": round(rtt_ms, 1), "latitudeDeg": gps["latitudeDeg"],
                           "fix": int(gps["fix"]), "solutionCount": gps["solutionCount"]}
            check("firmware: read gpsOut from the board", int(gps["fix"]) == 3 and 33.77 < gps["latitudeDeg"] < 33.78
                  and gps["solutionCount"] > 0,
                  f"lat {gps['latitudeDeg']:.6f}, fix {int(gps['fix'])}, solution {gps['solutionCount']} "
                  f"in {rtt_ms:.1f} ms")

            (pub,) = [p for p in fcs.table("pubsub") if p["content"] == "imuOut" and p["peer"] == "gcs1"]
            changed = fcs.set_period(pub["row"], SLOWER_MS)
            h.gcs.remote("gcs1").set_admin_row(int(row), period_ms=SLOWER_MS)
            h.run_for(0.5)
            t2 = h.mark(f"firmware: imuOut every {SLOWER_MS} ms")
            h.run_for(measure_s)
            hz = h.meter("imuOut", "fcs20").rate_hz(t2, None)
            want = 1000 / SLOWER_MS
            out["rate"] = {"row": pub["row"], "period_ms": [pub["period_ms"], SLOWER_MS], "achieved_hz": round(hz, 2)}
            check("firmware: change the board's rate", changed and abs(hz - want) <= CHANGED_TOLERANCE * want,
                  f"imuOut fcs20 -> gcs1: {pub['period_ms']} ms -> {SLOWER_MS} ms, {hz:.1f} Hz for {want:g} Hz")

            fcs.set("imuCalibration.gyro.bias", [0.25, 0.0, 0.0])
            t3 = time.monotonic()
            h.run_for(0.5)
            ps = [v["p"] for t, v in zip(h.meter("imuOut", "fcs20").times, h.meter("imuOut", "fcs20").values)
                  if t > t3 + 0.1]
            check("firmware: write the board's gyro bias", bool(ps) and all(abs(p - 0.25) < 0.01 for p in ps),
                  f"imuOut.p after the write: {ps[-1]:.3f} rad/s (bias 0.25)" if ps else "no imuOut after the write")
            (uart,) = fcs.table("links")
            out["uart"] = {k: uart[k] for k in ("frames_in", "frames_out", "bytes_in", "bytes_out", "drops")}
        say(f"  firmware: {size}; its UART: {out['uart']}")
    return out
