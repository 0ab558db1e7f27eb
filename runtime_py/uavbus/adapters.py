"""COTS device adapters for a Python node (issue #24): a GPS on a link becomes a catalogued directory.

The same adapters uavbus_node runs by port spec (`nmea:` and `ubx:`, programs/node/adapter_*.c), with one
implementation of each part, in C: the link's decoder splits uavbus frames from the device's bytes (the
node's foreign-traffic handler, Node.set_foreign_handler), the C parsers (ub_nmea.h, ub_ubx.h) decode the
device's protocol, and ub_gps_fields.h says which directory member gets which decoded value — the C
adapters expand that list at compile time, these classes read it through cffi. Python only moves values:

    node.open_port("gpsPort", "serial:device=/dev/ttyUSB0,baud=9600")
    gps = NmeaAdapter(node, "gpsPort", "gpsNmea")       # gpsNmea is now hosted and kept current
    node.publish("fcs20", "gpsNmea", "gcs1", 200)
    ... node.poll() ...; gps.stats["bad_checksum"]

Per run of foreign bytes the adapter feeds the parser once and then writes the directory: the fix (and the
time tag, node time) when at least one good sentence/message was merged, the counters always. The parser
merges sentence by sentence, so the directory ends each run exactly as the C adapter's does.
"""

from __future__ import annotations

from typing import Any, Callable

from uavbus._bindings import ub_gps
from uavbus.directory import Directory
from uavbus._bindings.ub_error import InvalidArgumentError, UbError


class _GpsAdapter:
    """What both adapters share: the directory, the foreign handler, writing the mapped members."""

    _values: Callable[..., list[tuple[str, float, bool]]]

    def __init__(self, node: Any, link: str, directory: str, parser: Any, type_name: str) -> None:
        self.node, self.link, self.name, self._parser = node, link, directory, parser
        self._out = ub_gps.values_buffer()  # reused at every run: no allocation per run
        mapped = [m for m, _, _ in self._values(parser, self._out)]
        t = node.catalogue.instance(directory).type
        fields = {f.name for f in t.packed_fields}
        missing = [m for m in ["time", *mapped] if m not in fields]
        if missing:  # checked before binding: a refused directory is not hosted
            raise InvalidArgumentError(
                f"directory {directory!r} is of type {t.name}, not {type_name}: no member "
                f"{', '.join(missing)} (catalogue it from examples/flightsw, docs/adapters.md)")
        d = node.bind(directory)
        self.directory: Directory = d
        # Integers arrive widened to double (exactly); an integer member's packer wants an int.
        self._float = {m for m in mapped if isinstance(getattr(d, m), float)}
        node.set_foreign_handler(link, self._feed)

    def _feed(self, data: bytes) -> None:  # the link's foreign-traffic handler: takes every byte
        if self._feed_parser(data) > 0:
            now = self.node.now()
            self.directory.time.seconds = now // 1000
            self.directory.time.microseconds = now % 1000 * 1000
            self._write(counters=False)
        self._write(counters=True)
        self._after_feed()

    def _feed_parser(self, data: bytes) -> int:
        raise NotImplementedError

    def _after_feed(self) -> None:
        pass

    def _write(self, counters: bool) -> None:
        d, floats = self.directory, self._float
        for member, value, is_counter in self._values(self._parser, self._out):
            if is_counter == counters:
                setattr(d, member, value if member in floats else int(value))

    def close(self) -> None:
        """Removes the foreign-traffic handler (the directory stays hosted, with its last values)."""
        self.node.set_foreign_handler(self.link, None)


class NmeaAdapter(_GpsAdapter):
    """An NMEA 0183 GPS on `link`: good GGA/RMC/VTG/GSA sentences into `directory` (type nmeaGps_t);
    bad ones counted (stats, and the directory's badChecksums/badSentences), never merged."""

    _values = staticmethod(ub_gps.nmea_dir_values)

    def __init__(self, node: Any, link: str, directory: str = "gpsNmea") -> None:
        super().__init__(node, link, directory, ub_gps.ub_nmea_new(), "nmeaGps_t")

    def _feed_parser(self, data: bytes) -> int:
        return ub_gps.ub_nmea_feed(self._parser, data)

    @property
    def stats(self) -> dict[str, int]:
        """The parser's counters (the names uavbus_node's `nmea:` port reports)."""
        return ub_gps.nmea_stats(self._parser)


class UbxAdapter(_GpsAdapter):
    """A u-blox receiver speaking UBX on `link`: good NAV-PVT into `directory` (type ubxGps_t).

    Writing, as uavbus_node's `ubx:` port: the directory `<directory>Cfg` (ubxCfg_t, hosted by this node when
    the catalogue has it) is the receiver's navigation rate. Whoever writes it (configure() here, or a
    publication from anywhere in the fleet), the adapter's service turn (Node.on_service) writes a
    UBX-CFG-RATE onto the link when it differs from what the receiver last answered, and the receiver's
    ACK-ACK/ACK-NAK, a time-out (one second, then sent again) are counted in the directory (cfgSent,
    cfgAcked, cfgNaked, cfgTimeouts, cfgMeasRateMs). The exchange is the C runtime's (ub_ubx_cfg_t)."""

    _values = staticmethod(ub_gps.ubx_dir_values)

    def __init__(self, node: Any, link: str, directory: str = "gpsUbx") -> None:
        super().__init__(node, link, directory, ub_gps.ub_ubx_new(), "ubxGps_t")
        self._rate = ub_gps.CfgRate()
        self._answers = 0
        self.cfg: Directory | None = None
        inst = node.catalogue.find(directory + "Cfg")
        if inst is not None and {"measRateMs", "navRate", "timeRef"} <= {f.name for f in inst.type.packed_fields}:
            self.cfg = node.bind(inst.name)
            node.on_service(self._service)

    def _feed_parser(self, data: bytes) -> int:
        return ub_gps.ub_ubx_feed(self._parser, data)

    def _after_feed(self) -> None:
        s = ub_gps.ubx_stats(self._parser)
        answers = s["ack"] + s["nak"]
        if answers != self._answers:  # the run's last answer (several in one run: the last one counts)
            self._answers = answers
            if self._rate.answer(self._parser):
                self._write_cfg()

    def _write_cfg(self) -> None:
        d = self.directory
        for member, value, _ in ub_gps.ubx_cfg_dir_values(self._rate.c, self._out):
            setattr(d, member, int(value))

    def _service(self, now_ms: int) -> None:
        c = self.cfg
        if c is None:
            return
        msg = self._rate.poll(c.measRateMs, c.navRate, c.timeRef, now_ms)
        if msg:
            try:
                self.node.write_foreign(self.link, msg)
                self._rate.sent(now_ms)
            except UbError:
                pass  # transmit buffer full or link down (counted by the link): the next turn tries again
        self._write_cfg()  # a time-out counts even when the resend could not be written

    def configure(self, meas_rate_ms: int, nav_rate: int = 1, time_ref: int = 0) -> None:
        """Writes the wanted rate into `<directory>Cfg`: the next service turn sends it (measRateMs 0: none)."""
        if self.cfg is None:
            raise InvalidArgumentError(f"{self.name}Cfg is not catalogued as ubxCfg_t: the receiver cannot be "
                                       "configured (examples/flightsw/ubx_gps.h declares gpsUbxCfg)")
        self.cfg.measRateMs, self.cfg.navRate, self.cfg.timeRef = meas_rate_ms, nav_rate, time_ref

    def close(self) -> None:
        self.node.remove_on_service(self._service)
        super().close()

    @property
    def stats(self) -> dict[str, int]:
        """The parser's counters (the names uavbus_node's `ubx:` port reports)."""
        return ub_gps.ubx_stats(self._parser)
