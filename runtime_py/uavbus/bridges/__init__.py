"""Bridges between uavbus and what users already run (docs/bridges.md): the MAVLink bridge's
directory names (`mavlink_dirs`; the bridge itself is the C program `uavbus_mavbridge`) and the
Zenoh bridge (`zenoh`, `uavbus bridge zenoh`)."""
