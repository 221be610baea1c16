"""One render and its files: the ``approx`` and ``reference`` commands' outputs."""
