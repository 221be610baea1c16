#!/usr/bin/env bash
# Prepare a machine for volcaustics: Debian system libraries, then .venv with the
# project installed editable (with test extras). Idempotent and fast when nothing
# changed: system packages are checked with dpkg, the venv is refreshed only when
# pyproject.toml (or this script) changed since the last install.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=.venv
STAMP="$VENV/.installed"
PYTHON=${PYTHON:-python3}

# --- system packages ---------------------------------------------------------
# libllvm19: Dr.Jit's LLVM backend needs libLLVM >= 16 (14/15 crash in the JIT).
# libegl1 + libgl1-mesa-dri: headless OpenGL (Mesa llvmpipe) for moderngl.
# glslang-tools: the Khronos reference GLSL compiler, make lint's shader check.
need=()
have_llvm=0
for lib in /usr/lib/x86_64-linux-gnu/libLLVM-{16,17,18,19,20,21}*.so* /usr/lib/llvm-{16,17,18,19,20,21}/lib/libLLVM*.so*; do
  [ -e "$lib" ] && have_llvm=1 && break
done
[ "$have_llvm" = 1 ] || need+=(libllvm19)
for pkg in libegl1 libgl1-mesa-dri glslang-tools; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if ! "$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1; then
  need+=(python3-venv)
fi
# apitrace, with --browser (make test): required, the display frame's test traces its GL calls for stalls.
if [ "${1:-}" = "--browser" ]; then
  dpkg -s apitrace >/dev/null 2>&1 || need+=(apitrace)
fi
# chromium + chromium-driver: the report's browser test (headless), with --browser
# (make test). Optional: without them that test is skipped and says why.
browser=()
if [ "${1:-}" = "--browser" ]; then
  for pkg in chromium chromium-driver; do
    dpkg -s "$pkg" >/dev/null 2>&1 || browser+=("$pkg")
  done
fi
if [ ${#browser[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "setup: installing ${browser[*]} (the report's browser test)"
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${browser[@]}" >/dev/null; } \
      || echo "setup: could not install ${browser[*]}: the report's browser test will be skipped" >&2
  else
    echo "setup: optional ${browser[*]} missing (the report's browser test will be skipped); to install:" >&2
    echo "  sudo apt-get install -y ${browser[*]}" >&2
  fi
fi
# The Khronos glTF-Validator (npm gltf-validator, this exact version) into .tools/ (git-ignored),
# for the glTF export's test, with --browser (make test). Optional: without Node.js/npm or
# the registry that test is skipped and says why.
GLTF_VALIDATOR=2.0.0-dev.3.10
if [ "${1:-}" = "--browser" ] \
   && ! grep -qs "\"version\": \"$GLTF_VALIDATOR\"" .tools/node_modules/gltf-validator/package.json; then
  if command -v npm >/dev/null; then
    echo "setup: installing gltf-validator@$GLTF_VALIDATOR into .tools/ (the glTF export's test)"
    npm install --prefix .tools --no-save --no-audit --no-fund --loglevel=error "gltf-validator@$GLTF_VALIDATOR" \
      >/dev/null || echo "setup: could not install gltf-validator: the glTF validation test will be skipped" >&2
  else
    echo "setup: optional npm missing (the glTF validation test will be skipped); install Node.js and npm" >&2
  fi
fi
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "setup: installing system packages: ${need[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "setup: missing system packages. Run:" >&2
    echo "  sudo apt-get update && sudo apt-get install -y ${need[*]}" >&2
    exit 1
  fi
fi

# --- virtual environment -----------------------------------------------------
# The install is setuptools' strict editable mode: a link tree (build/__editable__.*) that static
# tools follow, unlike the import hook of the default mode. A new or removed module needs a new
# link, so the list of the package's files is part of the stamp.
modules=$(find package infra scenes approx reference metrics experiment reports -type f \( -name '*.py' -o -name '*.glsl' \
          -o -name '*.toml' -o -name '*.ply' -o -name '*.md' -o -name '*.json' -o -name 'py.typed' \) -not -path '*/__pycache__/*' | sort)
want=$( { cat pyproject.toml setup.py scripts/setup.sh; echo "$modules"; } | sha256sum | cut -d' ' -f1)
if [ -x "$VENV/bin/python" ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ]; then
  exit 0
fi
[ -x "$VENV/bin/python" ] || "$PYTHON" -m venv "$VENV"
echo "setup: installing volcaustics into $VENV (strict editable, with test extras)"
"$VENV/bin/python" -m pip install -q --upgrade pip
rm -rf build/__editable__.volcaustics-*  # links to modules that no longer exist
"$VENV/bin/python" -m pip install -q -e ".[test]" --config-settings editable_mode=strict
echo "$want" > "$STAMP"
