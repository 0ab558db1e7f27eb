"""Python rates side by side (bench figure 4): uavbus Node publish/receive vs pymavlink and LCM Python.

    python bench/py_bench.py BENCHCAT.catalogue.json LCM_PY_DIR   -> lines "case<TAB>message<TAB>ops/s..."

Every case is calibrated to ~0.1 s per sample and sampled 5 times round-robin (drift hits all alike).
- uavbus publish: Publisher.send_many(timestamps, field=ts), 32 frames per call, each with its own timestamp
  (C: write the field into the bound wire image + header + CRC-32C + hand to the memlink, per frame);
  uavbus receive: the receiving Node.service(dispatch=False) (C: verify + dedup + copy into its directory, one
  record per delivery into the delivery ring, ub_rxring.h) + Node.receive().rows(inst): one drain call, every
  field of every delivery decoded into a tuple. Both through a MemLink between two in-process Nodes, in
  batches of 32.
- the per-message paths beside them: "uavbus publish, send() each" = set the timestamp attribute then
  Publisher.send(); "uavbus receive, Message each" = Node.service() dispatching one Message per delivery
  (with its raw image) to an on_data callback.
- pymavlink: msg.pack(mav) with the timestamp changed (encode); mav.decode(frame) (decode).
- LCM Python: obj.encode() with the timestamp changed; T.decode(bytes).
- uavbus catalogue codec (no node): Catalogue.encode(dict) / decode(bytes).
- "calls/msg <case>" lines: Python-level calls (Python functions + builtins, cffi functions included) per
  message over one warm batch of 32, counted with sys.setprofile: a figure the machine's load cannot move.
"""

from __future__ import annotations

import sys
import time
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from uavbus import Catalogue, MemLink, Node

SAMPLES = 5
BATCH = 32
MESSAGES = {  # uavbus instance, timestamp field, MAVLink class, LCM type name
    "ATTITUDE": ("benchAttitude", "time_boot_ms", "MAVLink_attitude_message", "attitude_t"),
    "GPS_RAW_INT": ("benchGpsRawInt", "time_usec", "MAVLink_gps_raw_int_message", "gps_raw_int_t"),
    "HIGHRES_IMU": ("benchHighresImu", "time_usec", "MAVLink_highres_imu_message", "highres_imu_t"),
}


def fill(cat: Catalogue, name: str) -> dict:
    """Every field non-zero (as in peers.md), so nothing is trimmed anywhere."""
    value = cat.default(name)
    for k, v in value.items():
        value[k] = 3 if isinstance(v, int) else 1.5 if isinstance(v, float) else v
    return value


def mavlink_message(cls_name: str, value: dict):
    cls = getattr(mavlink, cls_name)
    args = [value.get(f, 3) for f in cls.fieldnames]
    return cls(*args)


Case = tuple[str, str, Callable[[int], int]]


def cases_for(cat: Catalogue, lcm_mod, label: str) -> tuple[list[Case], dict[str, float]]:
    inst, ts, mav_cls, lcm_name = MESSAGES[label]
    value = fill(cat, inst)
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    msg = mavlink_message(mav_cls, value)
    frame = bytes(msg.pack(mav))
    lcm_type = getattr(lcm_mod, lcm_name)
    lobj = lcm_type()
    for k in lobj.__slots__:
        setattr(lobj, k, 3 if isinstance(getattr(lobj, k), int) else 1.5)
    lbytes = lobj.encode()
    payload = cat.encode(inst, value)

    tx = Node(cat, clock=lambda: 1.0)
    rx = Node(cat, clock=lambda: 1.0)
    tx.add_entity("tx", local=True), tx.add_entity("rx")
    rx.add_entity("rx", local=True), rx.add_entity("tx")
    tx.add_link("tx", 0, "l0"), rx.add_link("rx", 0, "l0")
    tx.set_mask("tx", "rx", 1)
    link = MemLink(tx, "l0", rx, "l0")
    pub = tx.publisher("tx", inst, "rx")  # names resolved once, as a periodic sender would
    d = pub.directory
    d.from_dict(value)
    rx.bind(inst)
    received = [0]

    def on_data(message) -> None:
        received[0] += 1

    spent = {"pub": 0.0, "recv": 0.0}

    def publish_batch(first: int) -> None:
        pub.send_many(range(first, first + BATCH), field=ts)

    def receive_batch() -> None:
        link.pump(1)
        rx.service(dispatch=False)
        rows = rx.receive().rows(inst)
        assert len(rows) == BATCH

    def node_roundtrip(n: int) -> int:
        """Batched: n publishes (send_many) and their receptions (one drain, rows); books each side's time."""
        done = 0
        while done < n:
            t0 = time.perf_counter()
            publish_batch(done)
            t1 = time.perf_counter()
            receive_batch()
            t2 = time.perf_counter()
            spent["pub"] += t1 - t0
            spent["recv"] += t2 - t1
            done += BATCH
        return done

    def node_roundtrip_each(n: int) -> int:
        """Per message: a send() per frame, a Message per delivery to an on_data callback."""
        rx.on_data(on_data)
        done = 0
        while done < n:
            t0 = time.perf_counter()
            for i in range(BATCH):
                setattr(d, ts, done + i)
                pub.send()
            t1 = time.perf_counter()
            link.pump(1)
            rx.service()
            t2 = time.perf_counter()
            spent["pub"] += t1 - t0
            spent["recv"] += t2 - t1
            done += BATCH
        rx._callbacks.clear()  # noqa: SLF001 - the batched case takes the deliveries itself
        return done

    def mav_encode(n: int) -> int:
        for i in range(n):
            setattr(msg, ts, i)
            msg.pack(mav)
        return n

    def mav_decode(n: int) -> int:
        buf = bytearray(frame)
        for _ in range(n):
            mav.decode(buf)
        return n

    def lcm_encode(n: int) -> int:
        for i in range(n):
            setattr(lobj, ts, i)
            lobj.encode()
        return n

    def lcm_decode(n: int) -> int:
        for _ in range(n):
            lcm_type.decode(lbytes)
        return n

    def cat_encode(n: int) -> int:
        for i in range(n):
            value[ts] = i
            cat.encode(inst, value)
        return n

    def cat_decode(n: int) -> int:
        for _ in range(n):
            cat.decode(inst, payload)
        return n

    def publish_each(first: int) -> None:
        for i in range(BATCH):
            setattr(d, ts, first + i)
            pub.send()

    def receive_each() -> None:
        rx.on_data(on_data)
        link.pump(1)
        rx.service()
        rx._callbacks.clear()  # noqa: SLF001

    def calls_per_message() -> list[tuple[str, float]]:
        """Python-level calls (Python functions and builtins, cffi's included) per message over one batch of
        each path: a count the machine's load cannot move, beside the rates it does."""
        def count(fn: Callable[[], object]) -> float:
            events = [0]

            def profile(frame, event, arg) -> None:  # noqa: ANN001 - sys.setprofile's signature
                if event in ("call", "c_call"):
                    events[0] += 1

            sys.setprofile(profile)
            try:
                fn()
            finally:
                sys.setprofile(None)
            return (events[0] - 1) / BATCH  # less the setprofile(None) call itself

        publish_batch(0), receive_batch(), publish_each(0), receive_each()  # warm: caches built on first use
        out = [("uavbus publish", count(lambda: publish_batch(0))), ("uavbus receive", count(receive_batch)),
               ("uavbus publish, send() each", count(lambda: publish_each(0))),
               ("uavbus receive, Message each", count(receive_each))]
        for name, fn in (("pymavlink encode", mav_encode), ("pymavlink decode", mav_decode),
                         ("lcm encode", lcm_encode), ("lcm decode", lcm_decode)):
            out.append((name, count(lambda fn=fn: fn(BATCH))))
        return out

    return [("node", label, node_roundtrip), ("node each", label, node_roundtrip_each),
            ("pymavlink encode", label, mav_encode),
            ("pymavlink decode", label, mav_decode), ("lcm encode", label, lcm_encode),
            ("lcm decode", label, lcm_decode), ("uavbus catalogue encode", label, cat_encode),
            ("uavbus catalogue decode", label, cat_decode)], spent, calls_per_message


def main() -> None:
    cat = Catalogue.load(sys.argv[1])
    sys.path.insert(0, sys.argv[2])
    import benchlcm  # generated by lcm-gen -p into build-bench/peers/lcmpy

    all_cases = []
    spents = {}
    counts = []
    for label in MESSAGES:
        cases, spent, calls_per_message = cases_for(cat, benchlcm, label)
        all_cases += cases
        spents[label] = spent
        counts += [(name, label, c) for name, c in calls_per_message()]
    iters = {}
    for name, label, fn in all_cases:  # calibrate
        n = 256
        while True:
            t0 = time.perf_counter()
            fn(n)
            dt = time.perf_counter() - t0
            if dt > 0.05:
                iters[(name, label)] = max(BATCH, int(n * 0.1 / dt) // BATCH * BATCH)
                break
            n *= 4
    rates: dict[tuple[str, str], list[float]] = {}
    for _ in range(SAMPLES):
        for name, label, fn in all_cases:
            n = iters[(name, label)]
            if name in ("node", "node each"):
                spent = spents[label]
                spent["pub"] = spent["recv"] = 0.0
                fn(n)
                suffix = "" if name == "node" else ", send() each"
                rates.setdefault(("uavbus publish" + suffix, label), []).append(n / spent["pub"])
                suffix = "" if name == "node" else ", Message each"
                rates.setdefault(("uavbus receive" + suffix, label), []).append(n / spent["recv"])
                continue
            t0 = time.perf_counter()
            fn(n)
            rates.setdefault((name, label), []).append(n / (time.perf_counter() - t0))
    for (name, label), r in rates.items():
        print("\t".join([name, label] + [f"{x:.0f}" for x in r]))
    for name, label, c in counts:  # "calls/msg <case>": one value, load-independent
        print(f"calls/msg {name}\t{label}\t{c:.2f}")


if __name__ == "__main__":
    main()
