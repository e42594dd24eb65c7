#!/usr/bin/env bash
# Replaces the generated section of a Markdown file: the lines between the markers
# "<!-- NAME: begin -->" and "<!-- NAME: end -->" become standard input. Fails, leaving the file as
# it was, when either marker is missing. Used by the scripts that write numbers into the docs.
#
# Usage: some-script | scripts/write-section.sh FILE NAME
set -euo pipefail
file=${1:?file}; name=${2:?section name}
begin="<!-- $name: begin -->"
end="<!-- $name: end -->"
grep -qxF "$begin" "$file" && grep -qxF "$end" "$file" || {
  echo "write-section.sh: markers '$begin' and '$end' not found in $file" >&2
  exit 1
}
section=$(mktemp)
trap 'rm -f "$section" "$file.tmp"' EXIT
cat >"$section"
awk -v b="$begin" -v e="$end" -v f="$section" '
  $0 == b { print; while ((getline l < f) > 0) print l; skip = 1; next }
  $0 == e { skip = 0 }
  !skip { print }' "$file" >"$file.tmp"
mv "$file.tmp" "$file"
