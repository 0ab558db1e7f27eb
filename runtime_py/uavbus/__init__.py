"""uavbus: publish/subscribe for teams of UAVs and ground stations (AIAA 2005-6309).

`Catalogue` is pure Python; `Node`, `MemLink`, `Admin`, `Directory` and `Message` load the C runtime
(uavbus._ub) on first use, so tools that only decode never need it.
"""

from typing import Any

from uavbus.catalogue import Catalogue, Instance, Type

__version__ = "0.1.0"

__all__ = ["Admin", "Catalogue", "Directory", "Instance", "MemLink", "Membership", "Message", "Node", "Type",
           "__version__"]

_LAZY = {"Node": "uavbus.node", "MemLink": "uavbus.node", "Admin": "uavbus.node", "Message": "uavbus.node",
         "Membership": "uavbus.node", "Directory": "uavbus.directory"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'uavbus' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
