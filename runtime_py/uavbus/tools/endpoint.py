"""Raw frame senders for `uavbus log play --into SPEC` (SPEC as Contract 1's CLI form).

Playback sends the recorded frames exactly as they are (same source, seq, content, checks), so the
receiving node cannot tell them from the original traffic. No node is needed on this side:

    udp:peer=HOST:PORT[,bind=HOST:PORT]   one datagram per frame
    tcp:connect=HOST:PORT                 connect, then write the frames as one stream
    serial:device=PATH[,baud=N]           raw 8N1 at the baud rate (default 115200), frames written as a stream
"""

from __future__ import annotations

import os
import socket
import termios
import tty
from typing import Protocol

BAUDS = {9600: termios.B9600, 19200: termios.B19200, 38400: termios.B38400, 57600: termios.B57600,
         115200: termios.B115200, 230400: termios.B230400}
PARAMS = {"udp": ("peer", "bind"), "tcp": ("connect",), "serial": ("device", "baud")}


class SpecError(ValueError):
    """A bad endpoint spec; the message says what to write instead."""


class FrameSink(Protocol):
    def send(self, frame: bytes) -> None: ...
    def close(self) -> None: ...


def parse_spec(text: str) -> tuple[str, dict[str, str]]:
    """'udp:peer=127.0.0.1:5001' -> ('udp', {'peer': '127.0.0.1:5001'})."""
    transport, _, rest = text.partition(":")
    if transport not in PARAMS:
        raise SpecError(f"endpoint '{text}': transport must be one of {', '.join(PARAMS)} "
                        "(e.g. udp:peer=127.0.0.1:5001, tcp:connect=127.0.0.1:5001, serial:device=/dev/pts/3)")
    params: dict[str, str] = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq or key not in PARAMS[transport]:
            raise SpecError(f"endpoint '{text}': '{item}' is not a {transport} parameter "
                            f"(expected {', '.join(p + '=...' for p in PARAMS[transport])})")
        params[key] = value
    need = {"udp": "peer", "tcp": "connect", "serial": "device"}[transport]
    if need not in params:
        raise SpecError(f"endpoint '{text}': playback into {transport} needs {need}=...")
    return transport, params


def host_port(text: str, what: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise SpecError(f"{what} '{text}' is not HOST:PORT (e.g. 127.0.0.1:5001)")
    return host or "127.0.0.1", int(port)


class UdpSink:
    def __init__(self, peer: tuple[str, int], bind: tuple[str, int] | None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if bind is not None:
            self.sock.bind(bind)
        self.peer = peer

    def send(self, frame: bytes) -> None:
        self.sock.sendto(frame, self.peer)

    def close(self) -> None:
        self.sock.close()


class StreamSink:
    """A TCP connection or a serial device: frames go out back to back as one byte stream."""

    def __init__(self, fd: int, sock: socket.socket | None = None) -> None:
        self.fd, self.sock = fd, sock

    def send(self, frame: bytes) -> None:
        view = memoryview(frame)
        while view:
            view = view[os.write(self.fd, view):]

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        else:
            os.close(self.fd)


def open_sink(text: str) -> FrameSink:
    """Opens the endpoint of `text`; raises SpecError or OSError (with the endpoint in the message)."""
    transport, params = parse_spec(text)
    try:
        if transport == "udp":
            bind = host_port(params["bind"], "bind") if "bind" in params else None
            return UdpSink(host_port(params["peer"], "peer"), bind)
        if transport == "tcp":
            sock = socket.create_connection(host_port(params["connect"], "connect"), timeout=5.0)
            sock.setblocking(True)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return StreamSink(sock.fileno(), sock)
        baud = int(params.get("baud", "115200")) if params.get("baud", "115200").isdigit() else -1
        if baud not in BAUDS:
            raise SpecError(f"endpoint '{text}': baud must be one of {', '.join(map(str, BAUDS))}")
        fd = os.open(params["device"], os.O_RDWR | os.O_NOCTTY)
        try:
            tty.setraw(fd)
            attrs = termios.tcgetattr(fd)
            attrs[4] = attrs[5] = BAUDS[baud]
            termios.tcsetattr(fd, termios.TCSANOW, attrs)
        except termios.error as exc:
            os.close(fd)
            code = exc.args[0] if exc.args and isinstance(exc.args[0], int) else 0
            raise OSError(code, f"{params['device']} is not a serial device ({os.strerror(code) if code else exc})"
                          ) from None
        return StreamSink(fd)
    except OSError as exc:
        raise OSError(exc.errno, f"cannot open endpoint '{text}': {exc.strerror}") from exc
