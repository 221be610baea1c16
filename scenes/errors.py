"""The one error type of scene loading and validation."""

from __future__ import annotations

from typing import Any

from volcaustics.infra.errors import InputError


class SceneError(InputError):
    """A scene file or scene value is invalid.

    The message always names where (file), what (key, as a dotted path such as
    ``specular[0].ior``), the offending value and what is allowed, so the CLI can
    print it on one or two lines and a user can fix the file without a traceback.

    Parameters
    ----------
    file : str or None
        Scene file (or ``"<built-in NAME>"``); None when the scene was built in code.
    key : str or None
        Dotted key path; None for whole-file problems (TOML syntax).
    value : Any
        The offending value (printed with ``repr``, shortened in the middle).
    allowed : str
        What would be accepted, phrased as the fix.
    """

    def __init__(self, file: str | None, key: str | None, value: Any, allowed: str):
        self.file = file
        self.key = key
        self.value = value
        self.allowed = allowed
        super().__init__(self._format())

    def _format(self) -> str:
        where = self.file or "<scene>"
        text = repr(self.value)
        if len(text) > 80:  # the middle goes: a path keeps its file name, a list its last items
            text = text[:38] + "..." + text[-39:]
        if self.key is None:
            return f"{where}: {self.allowed}"
        return f"{where}: {self.key} = {text}: {self.allowed}"
