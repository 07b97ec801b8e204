#!/usr/bin/env bash
# Builds the third-party blind-target FMUs from the sources in tests/thirdparty/ (no committed
# binaries):
#   target/thirdparty/BuckPy.fmu  pythonfmu (in .venv, from scripts/requirements.txt)
#   target/thirdparty/BuckQ.fmu   qfmu (in its own venv .venv-qfmu, scripts/requirements-qfmu.txt)
# Idempotent and quick when up to date: an FMU is rebuilt only when a stamp of its inputs (this
# script, its source, the tool's requirement) changed. Venvs are made when missing.
# Environment: PYTHON3 (interpreter for the qfmu venv; default python3.11 when it runs, else
# python3: qfmu pins numpy 1.24.4, which has no wheels past Python 3.11), QFMU_VENV (default
# .venv-qfmu; it gets a .gitignore of its own).
# Prints the paths of the FMUs it wrote on stdout, progress on stderr. A missing C compiler
# skips BuckQ.fmu with a "SKIP" line (exit 0, no FMU); anything else that fails is an error.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
src=tests/thirdparty
out=target/thirdparty
mkdir -p "$out"
python3=${PYTHON3:-python3}
if [ -z "${PYTHON3:-}" ] && python3.11 -c '' 2>/dev/null; then python3=python3.11; fi

stamp_of() { cat "$@" | sha256sum | cut -d' ' -f1; }

# ---- pythonfmu → BuckPy.fmu -----------------------------------------------------------------
if ! .venv/bin/python -c 'import pythonfmu' 2>/dev/null; then
  echo "thirdparty: .venv lacks pythonfmu, running scripts/setup" >&2
  scripts/setup
fi
if ! .venv/bin/python -c 'import pythonfmu' 2>/dev/null; then
  req=$(grep -E '^pythonfmu' scripts/requirements.txt | cut -d'#' -f1 | tr -d ' ')
  echo "thirdparty: installing ${req:-pythonfmu} into .venv" >&2
  .venv/bin/pip install -q --disable-pip-version-check "${req:-pythonfmu}"
fi
want=$( { grep -E '^pythonfmu' scripts/requirements.txt; cat "$src/build.sh" "$src/pythonfmu/buck_py.py"; } | sha256sum | cut -d' ' -f1)
if [ ! -f "$out/BuckPy.fmu" ] || [ "$(cat "$out/BuckPy.fmu.stamp" 2>/dev/null)" != "$want" ]; then
  echo "thirdparty: building BuckPy.fmu with pythonfmu" >&2
  rm -f "$out/BuckPy.fmu" "$out/BuckPy.fmu.stamp"
  # pythonfmu imports the script to write the modelDescription: keep its bytecode out of the tree.
  PYTHONDONTWRITEBYTECODE=1 .venv/bin/python -m pythonfmu build -f "$src/pythonfmu/buck_py.py" -d "$out" >&2
  [ -f "$out/BuckPy.fmu" ] || { echo "thirdparty: pythonfmu did not write $out/BuckPy.fmu" >&2; exit 1; }
  echo "$want" > "$out/BuckPy.fmu.stamp"
fi
echo "$root/$out/BuckPy.fmu"

# ---- qfmu → BuckQ.fmu -----------------------------------------------------------------------
cc=$(command -v gcc || true)
if [ -z "$cc" ]; then
  echo "thirdparty: SKIP BuckQ.fmu: qfmu compiles with gcc, which is not installed" >&2
  exit 0
fi
qvenv=${QFMU_VENV:-.venv-qfmu}
qstamp=$qvenv/.requirements.sha
qwant=$(stamp_of scripts/requirements-qfmu.txt)
if [ ! -x "$qvenv/bin/python" ] || [ "$(cat "$qstamp" 2>/dev/null)" != "$qwant" ]; then
  echo "thirdparty: creating $qvenv with scripts/requirements-qfmu.txt" >&2
  "$python3" -m venv "$qvenv"
  echo '*' > "$qvenv/.gitignore"
  "$qvenv/bin/pip" install -q --disable-pip-version-check -r scripts/requirements-qfmu.txt
  echo "$qwant" > "$qstamp"
fi
want=$(stamp_of scripts/requirements-qfmu.txt "$src/build.sh" "$src/qfmu/build_buckq.py")
if [ ! -f "$out/BuckQ.fmu" ] || [ "$(cat "$out/BuckQ.fmu.stamp" 2>/dev/null)" != "$want" ]; then
  echo "thirdparty: building BuckQ.fmu with qfmu" >&2
  rm -f "$out/BuckQ.fmu" "$out/BuckQ.fmu.stamp"
  "$qvenv/bin/python" "$src/qfmu/build_buckq.py" "$out" >&2
  [ -f "$out/BuckQ.fmu" ] || { echo "thirdparty: qfmu did not write $out/BuckQ.fmu" >&2; exit 1; }
  echo "$want" > "$out/BuckQ.fmu.stamp"
fi
echo "$root/$out/BuckQ.fmu"
