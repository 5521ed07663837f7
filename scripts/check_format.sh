#!/usr/bin/env bash
# Fails when a C++ or CUDA source of the repository is not in the shape .clang-format gives it
# (CI runs it first). Fix with: git ls-files '*.h' '*.cpp' '*.cu' '*.cuh' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "check_format: clang-format is not installed (scripts/setup.sh)" >&2; exit 2; }
files=$(git ls-files '*.h' '*.hpp' '*.cpp' '*.cu' '*.cuh')
if ! clang-format --dry-run -Werror $files; then
  echo "check_format: the files above differ from .clang-format's shape ($(clang-format --version))" >&2
  exit 1
fi
echo "check_format: $(echo "$files" | wc -l) files formatted ($(clang-format --version | sed 's/.*version //'))"
