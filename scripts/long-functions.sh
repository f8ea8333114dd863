#!/usr/bin/env bash
# Function-length census of the C++ sources: every function body (namespace-scope functions,
# member functions, functions defined inside a struct; lambdas count towards the function that
# holds them) with its length in lines, from its header's opening brace to its closing brace.
#
#   scripts/long-functions.sh [--limit N] [--all] [paths...]   (default: --limit 80 src)
#
# Prints `file:line: N lines: header` for each function over the limit (with --all: every
# function, longest first) and exits 1 when any function is over the limit. Comments, string
# and character literals are stripped before the braces are counted.
set -euo pipefail

limit=80
all=0
paths=()
while [ $# -gt 0 ]; do
  case "$1" in
    --limit) limit="$2"; shift 2 ;;
    --all) all=1; shift ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) paths+=("$1"); shift ;;
  esac
done
[ ${#paths[@]} -gt 0 ] || paths=(src)
cd "$(dirname "$0")/.."

files=$(find "${paths[@]}" -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' -o -name '*.cc' \) | sort)
[ -n "$files" ] || { echo "long-functions: no C++ files under ${paths[*]}" >&2; exit 2; }

# shellcheck disable=SC2086
awk -v limit="$limit" -v all="$all" '
function flush_header(   h) { header = "" }
# Is the text before an opening brace the header of a function body?
function is_function(h,   s, before) {
  s = h
  gsub(/^[ \t]+|[ \t]+$/, "", s)
  if (s == "" || index(s, ")") == 0) return 0
  if (s ~ /^(namespace|struct|class|union|enum|extern)[ \t{]/ || s ~ /^(namespace|struct|class|union|enum)$/) return 0
  if (s ~ /^(if|for|while|switch|catch|do|else)[ \t(]/) return 0
  gsub(/operator[^(]*\(/, "operator(", s)
  before = substr(s, 1, index(s, "(") - 1)
  if (before ~ /=/) return 0            # a variable initialised with a lambda or a brace list
  if (before ~ /\[/) return 0           # a lambda
  return 1
}
FNR == 1 { depth = 0; fdepth = -1; header = ""; in_block = 0 }
{
  line = $0
  out = ""
  n = length(line)
  i = 1
  while (i <= n) {
    c = substr(line, i, 1)
    if (in_block) {
      if (substr(line, i, 2) == "*/") { in_block = 0; i += 2 } else i++
      continue
    }
    two = substr(line, i, 2)
    if (two == "//") break
    if (two == "/*") { in_block = 1; i += 2; continue }
    if (c == "\"" || c == "\x27") {        # string or character literal (raw strings not used)
      q = c; i++
      while (i <= n && substr(line, i, 1) != q) { if (substr(line, i, 1) == "\\") i++; i++ }
      i++
      out = out q q
      continue
    }
    out = out c
    i++
  }
  if (out ~ /^[ \t]*#/) next             # preprocessor line
  for (i = 1; i <= length(out); i++) {
    c = substr(out, i, 1)
    if (c == "{") {
      if (fdepth < 0 && is_function(header)) {
        fdepth = depth; fstart = FNR; fname = header
        gsub(/^[ \t]+|[ \t]+$/, "", fname); gsub(/[ \t]+/, " ", fname)
      }
      depth++; header = ""
    } else if (c == "}") {
      depth--; header = ""
      if (fdepth >= 0 && depth == fdepth) {
        len = FNR - fstart + 1
        if (all || len > limit) printf "%d\t%s:%d: %d lines: %s\n", len, FILENAME, fstart, len, substr(fname, 1, 100)
        fdepth = -1
      }
    } else if (c == ";") {
      header = ""
    } else if (fdepth < 0) {
      header = header c
    }
  }
  if (fdepth < 0) header = header " "
}
' $files | sort -t$'\t' -k1,1nr | cut -f2- > /tmp/long-functions.$$ || true

if [ "$all" = 1 ]; then
  cat /tmp/long-functions.$$
  over=$(awk -v limit="$limit" -F': ' '{ split($2, a, " "); if (a[1] + 0 > limit) n++ } END { print n + 0 }' /tmp/long-functions.$$)
else
  cat /tmp/long-functions.$$
  over=$(wc -l < /tmp/long-functions.$$)
fi
rm -f /tmp/long-functions.$$
if [ "$over" -gt 0 ]; then
  echo "long-functions: $over function(s) over $limit lines" >&2
  exit 1
fi
