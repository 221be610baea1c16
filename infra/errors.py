"""The one error type of bad input.

Every error a user can fix (a scene file, a parameter, a spec, a path, a budget, an
option) derives from :class:`InputError`; the command line catches it alone and exits 2
with its message, which names the file or option, the key, the value and what is allowed.
Faults of the machine (a full disk, a killed worker) are not input errors.
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad input the user can fix; the message names where, what, the value and the fix."""
