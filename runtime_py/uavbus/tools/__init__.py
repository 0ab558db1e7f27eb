"""The uavbus tools: log info/export/play, spy, echo, hz, tables (decoded from the catalogue)."""
