"""The report: a static HTML page of sound fields (``sonolux report``), and the measuring
commands ``params`` and ``report`` (:mod:`sonolux.report.commands`)."""
