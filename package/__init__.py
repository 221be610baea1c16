"""volcaustics: a validation harness for Real-time Volume Caustics with Image-based
Photon Tracing (Wang, Wang & Chen).

The installed namespace of the repository's top-level folders: ``volcaustics.scenes``,
``volcaustics.approx``, ``volcaustics.reference``, ``volcaustics.metrics`` and
``volcaustics.reports`` are the folders ``scenes/``, ``approx/``, ``reference/``,
``metrics/`` and ``reports/`` (``pyproject.toml`` maps them with setuptools'
``package-dir``), so no bare name that belongs to another distribution is installed.
"""
