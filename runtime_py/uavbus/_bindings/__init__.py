"""Tier 2 of the cffi layer: thin 1:1 wrappers over `uavbus._ub`, one module per C header.

Each wrapper validates its arguments, calls the C function and turns a negative return code into a
`UbError` subclass (see `ub_error`). Values are plain Python (bytes, int, small dataclasses); the
Pythonic API is built on top of these.
"""
