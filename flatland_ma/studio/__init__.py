"""``flatland-ma studio``: a local web app to design, watch and play scenarios in a browser.

The top floor of the package under the command line: it uses every layer below, and only
the command line imports it (``flatland_ma.cli.studio`` serves it). Its pieces:

- ``config``: the folders it may read and write, the token, and the limits;
- ``folders``: file names checked to stay inside the given folders;
- ``scenarios``: YAML text to a checked scenario with located problems, and pictures;
- ``episodes``: a watched or played episode, stepped a frame at a time;
- ``sockets``: the WebSocket protocol that drives an episode (its messages checked in
  ``socket_messages``);
- ``api``: the HTTP endpoints; ``app``: the ASGI app with its guards (token, host,
  origin, request size); ``serving``: the server's options (the subcommand itself is
  ``flatland_ma.cli.studio``).

The pages are built once from ``studio/frontend`` (``make studio-assets``) into
``static/``, shipped as package data: the app needs no network when it runs.
Starlette and uvicorn come with the ``studio`` extra (in a clone of flatland_ma:
``pip install -e '.[studio]'``).
"""
