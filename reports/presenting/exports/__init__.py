"""The files of the commands that write one render or one scene: the ``approx`` and
``reference`` commands' outputs, and the glTF 2.0 export (``export``)."""
