"""`uavbus web`: the operator's console in the browser (docs/web.md).

`console.Console` owns the node on its own thread; `server.make_app()` is the aiohttp application over it;
`static/` holds every script and style the pages use (shipped in the wheel, nothing fetched at run time).
"""
