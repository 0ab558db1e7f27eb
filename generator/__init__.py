"""uavbus_gen: flight-software C headers -> checked directory catalogue -> C and Python codecs.

Three stages: `frontend` (the only module that imports clang) -> `model` (validated, immutable)
-> `render` (Jinja2 templates named after model classes).
"""
