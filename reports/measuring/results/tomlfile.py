"""Reading the TOML files of the reports (sweep specs, gate budgets): the document, or
an InputError naming the file and what is wrong — never a traceback."""

from __future__ import annotations

from collections.abc import Collection

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from volcaustics.infra.errors import InputError
from volcaustics.infra.storage import special_file_kind


def load_toml(path: str, *, keys: Collection[str], what: str) -> dict:
    """The TOML document at ``path`` whose top-level keys are among ``keys``; InputError
    (an exception type) for an unreadable file, bad TOML or an unknown key."""
    kind = special_file_kind(path)
    if kind:
        raise InputError(f"{path}: cannot read the {what} (it is {kind})")
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the {what} ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, RecursionError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    unknown = sorted(set(doc) - set(keys))
    if unknown:
        raise InputError(f"{path}: unknown key {unknown[0]!r}; expected {', '.join(keys)}")
    return doc
