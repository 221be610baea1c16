"""``volcaustics report``: gather every scene's results, the sweep's, the animations' and
other renderers' (``run``; a sweep store read back by ``sweep_store``), then draw the page
(``reports.presenting.page``). The only part of the report that measures."""
