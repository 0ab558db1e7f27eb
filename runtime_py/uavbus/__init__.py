"""uavbus: publish/subscribe for teams of UAVs and ground stations (AIAA 2005-6309)."""

__version__ = "0.1.0"
