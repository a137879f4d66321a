"""``python -m sonolux.cli``: the same as the ``sonolux`` command."""

import sys

from sonolux.cli.main import main

sys.exit(main())
