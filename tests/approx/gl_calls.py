"""A Python script's GL calls, as apitrace records them: run the script under
``apitrace trace --api egl``, read ``apitrace dump`` back as :class:`GLCall` rows, cut out
the calls of each debug group (``approx.debug_groups``) and pick those that make the CPU
wait for the GPU.

apitrace is a required test tool (Debian package ``apitrace``; ``bash scripts/setup.sh
--browser``, which ``make test`` runs, installs it): without it :func:`trace_script`
raises :class:`ApitraceMissing`, and the tests that trace fail saying so."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import sys
from pathlib import Path

INSTALL = "bash scripts/setup.sh --browser"

# Reads of pixels into client memory; with a buffer bound to GL_PIXEL_PACK_BUFFER they
# write into that buffer on the GPU's timeline instead, and do not wait.
PIXEL_READS = frozenset({
    "glReadPixels", "glReadnPixels", "glGetTexImage", "glGetnTexImage", "glGetTextureImage",
    "glGetTextureSubImage", "glGetCompressedTexImage", "glGetnCompressedTexImage",
    "glGetCompressedTextureImage", "glGetCompressedTextureSubImage",
})
BUFFER_READS = frozenset({"glGetBufferSubData", "glGetNamedBufferSubData"})
ACCESS_MAPS = frozenset({"glMapBuffer", "glMapNamedBuffer"})          # access: GL_READ_ONLY, ...
RANGE_MAPS = frozenset({"glMapBufferRange", "glMapNamedBufferRange"})  # access: GL_MAP_*_BIT | ...
QUERY_GETS = frozenset({"glGetQueryObjectiv", "glGetQueryObjectuiv", "glGetQueryObjecti64v",
                        "glGetQueryObjectui64v"})

CALL = re.compile(r"(\d+) (\w+)\(")
SUFFIX = re.compile(r"(ARB|EXT|KHR|OES)$")


class ApitraceMissing(RuntimeError):
    """apitrace is not on PATH; the message says how to install it."""


@dataclasses.dataclass(frozen=True)
class GLCall:
    """One call of an ``apitrace dump``: its number in the trace, the function's name, the
    argument text as dumped (``name = value, ...``, enums by name) and the return value's
    text (None for void)."""

    index: int
    name: str
    args: str
    result: str | None = None

    def arg(self, name: str) -> str | None:
        """The dumped value of argument ``name`` (a string keeps its quotes), or None."""
        for part in split_top_level(self.args):
            key, sep, value = part.partition(" = ")
            if sep and key.strip() == name:
                return value.strip()
        return None


def brackets(text: str, start: int = 0):
    """(index, character, depth) for each character of ``text[start:]`` outside string
    literals (apitrace escapes quotes in them); ``depth`` counts the brackets open after it."""
    depth, quoted, escaped = 0, False, False
    for i in range(start, len(text)):
        char = text[i]
        if quoted:
            escaped, quoted = char == "\\" and not escaped, escaped or char != '"'
            continue
        quoted = char == '"'
        depth += (char in "({[") - (char in ")}]")
        yield i, char, depth


def split_top_level(text: str) -> list[str]:
    """``text`` cut at the commas outside brackets and string literals."""
    cuts = [i for i, char, depth in brackets(text) if char == "," and depth == 0]
    parts = [text[i + 1:j] for i, j in zip([-1, *cuts], [*cuts, len(text)])]
    return [part.strip() for part in parts if part.strip()]


def closing_paren(text: str, start: int) -> int:
    """Index of the ``)`` that closes the argument list opened just before ``start``."""
    for i, _, depth in brackets(text, start):
        if depth == -1:
            return i
    raise ValueError(f"unbalanced call line: {text[:200]!r}")


def parse_dump(text: str) -> list[GLCall]:
    """The calls of ``apitrace dump --multiline=false`` output, in order (comment and
    blank lines skipped; apitrace's fake ``memcpy`` rows of mapped writes kept)."""
    calls = []
    for line in text.splitlines():
        found = CALL.match(line)
        if found is None:
            continue
        end = closing_paren(line, found.end())
        rest = line[end + 1:].split(" // ", 1)[0].strip()
        result = rest[2:].strip() if rest.startswith("= ") else None
        calls.append(GLCall(int(found.group(1)), found.group(2), line[found.end():end], result))
    return calls


def trace_script(script: Path, args: list[str], workdir: Path, timeout: float = 300) -> list[GLCall]:
    """Run ``python script *args`` (this interpreter, in ``workdir``) under apitrace's EGL
    wrapper and return every call it made. ApitraceMissing without apitrace;
    RuntimeError (with the output's tail) when the script or apitrace fails."""
    apitrace = shutil.which("apitrace")
    if apitrace is None:
        raise ApitraceMissing(f"apitrace is not on PATH (Debian package apitrace): run `{INSTALL}`")
    trace = Path(workdir) / f"{Path(script).stem}.trace"
    done = subprocess.run([apitrace, "trace", "--api", "egl", "--output", str(trace), sys.executable, str(script),
                           *args], cwd=workdir, capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0 or not trace.exists():
        raise RuntimeError(f"apitrace trace of {script} exited {done.returncode}:\n"
                           f"{(done.stdout + done.stderr)[-3000:]}")
    dump = subprocess.run([apitrace, "dump", "--color=never", "--multiline=false", str(trace)],
                          capture_output=True, text=True, timeout=timeout)
    if dump.returncode != 0:
        raise RuntimeError(f"apitrace dump {trace} exited {dump.returncode}: {dump.stderr[-3000:]}")
    return parse_dump(dump.stdout)


def string_value(value: str | None) -> str | None:
    """The text of a dumped string literal (``"..."``, escapes undone), else None."""
    if value is None or len(value) < 2 or value[0] != '"' or value[-1] != '"':
        return None
    return re.sub(r"\\(.)", r"\1", value[1:-1])


def frames(calls: list[GLCall], label: str) -> list[list[GLCall]]:
    """The calls inside each ``glPushDebugGroup`` whose message is ``label`` and its
    matching ``glPopDebugGroup`` (groups nested inside count as calls of the frame), in
    order; the push and the pop themselves left out. ValueError for a group never popped."""
    found: list[list[GLCall]] = []
    depth, inside = 0, None
    for call in calls:
        if call.name == "glPushDebugGroup":
            depth += 1
            if inside is None and string_value(call.arg("message")) == label:
                inside, opened = [], depth
                continue
        elif call.name == "glPopDebugGroup":
            if inside is not None and depth == opened:
                found.append(inside)
                inside = None
                depth -= 1
                continue
            depth -= 1
        if inside is not None:
            inside.append(call)
    if inside is not None:
        raise ValueError(f"debug group {label!r} pushed and never popped ({len(inside)} calls after it)")
    return found


def blocking_calls(calls: list[GLCall]) -> list[GLCall]:
    """The calls that make the CPU wait for the GPU: glFinish; reads of pixels into client
    memory (glReadPixels, glGetTexImage, glGetTextureImage, ... with no buffer bound to
    GL_PIXEL_PACK_BUFFER); glGetBufferSubData and glGetNamedBufferSubData; maps for reading
    (glMapBuffer*/glMapNamedBuffer* with GL_READ_ONLY or GL_READ_WRITE, or the *Range forms
    with GL_MAP_READ_BIT); glGetQueryObject* asking GL_QUERY_RESULT into client memory (no
    buffer bound to GL_QUERY_BUFFER); glClientWaitSync with a non-zero timeout.

    Not blocking: GL_QUERY_RESULT_AVAILABLE and GL_QUERY_RESULT_NO_WAIT; glWaitSync (the
    GPU waits, not the CPU); glGetQueryBufferObject* and reads into a bound pack or query
    buffer (ARB_query_buffer_object, pixel buffer objects: the GPU writes the buffer later);
    glClientWaitSync with timeout 0 (a poll); maps for writing and glBufferSubData (a driver
    may still stall a synchronised write map on a busy buffer: not counted). Vendor
    suffixes (ARB, EXT, ...) are ignored. Buffer bindings are followed from the first call
    given, nothing bound before it."""
    found = []
    pack_bound = query_bound = False
    for call in calls:
        name = SUFFIX.sub("", call.name)
        if name == "glBindBuffer":
            target, bound = call.arg("target"), call.arg("buffer") not in (None, "0")
            pack_bound = bound if target == "GL_PIXEL_PACK_BUFFER" else pack_bound
            query_bound = bound if target == "GL_QUERY_BUFFER" else query_bound
        elif (name == "glFinish" or name in BUFFER_READS or (name in PIXEL_READS and not pack_bound)
              or (name in ACCESS_MAPS and call.arg("access") in ("GL_READ_ONLY", "GL_READ_WRITE"))
              or (name in RANGE_MAPS and "GL_MAP_READ_BIT" in (call.arg("access") or "").split(" | "))
              or (name in QUERY_GETS and call.arg("pname") == "GL_QUERY_RESULT" and not query_bound)
              or (name == "glClientWaitSync" and call.arg("timeout") != "0")):
            found.append(call)
    return found
