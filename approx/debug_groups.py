"""Named groups of GL work (``glPushDebugGroup``/``glPopDebugGroup``, core in GL 4.3):
apitrace dumps, RenderDoc and vendor profilers show them as markers, so a display frame
can be found in a trace and its calls checked (tests/approx/gl_calls.py)."""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator

from .gl_entry import current_gl_version, gl_function

DISPLAY_FRAME = "volcaustics display frame"
DEBUG_SOURCE_APPLICATION = 0x824A  # GL_DEBUG_SOURCE_APPLICATION
DEBUG_GROUPS_SINCE = (4, 3)


@contextlib.contextmanager
def debug_group(label: str) -> Iterator[None]:
    """Wrap the GL work of the block in a debug group named ``label`` (ASCII/UTF-8, at
    most GL_MAX_DEBUG_MESSAGE_LENGTH bytes, 4096 on Mesa) on the current context; a
    no-op with no current context or one older than GL 4.3. The group is popped even
    when the block raises, so the group stack stays balanced."""
    version = current_gl_version()
    push = gl_function("glPushDebugGroup", None, ctypes.c_uint, ctypes.c_uint, ctypes.c_int, ctypes.c_char_p)
    pop = gl_function("glPopDebugGroup", None)
    if version is None or version < DEBUG_GROUPS_SINCE or push is None or pop is None:
        yield
        return
    message = label.encode()
    push(DEBUG_SOURCE_APPLICATION, 0, len(message), message)
    try:
        yield
    finally:
        pop()
