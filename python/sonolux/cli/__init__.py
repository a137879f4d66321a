"""The ``sonolux`` command line: thin shells over the library, one module per family.

- :mod:`~sonolux.cli.main`: the parser, the error handling, :func:`main`;
- :mod:`~sonolux.cli.args`: parsers of the values the commands share (X,Y, counts, ranges);
- :mod:`~sonolux.cli.scene`: ``check``, ``bake``, ``info``, ``ir``, ``experiment``;
- :mod:`~sonolux.cli.light`: ``render`` and ``export`` (glTF and the web bundle);
- :mod:`~sonolux.cli.measure`: ``params`` and ``report``;
- :mod:`~sonolux.cli.listen`: ``auralize`` and ``serve``.

Nothing in the library imports this package.
"""

from sonolux.cli.main import main

__all__ = ["main"]
