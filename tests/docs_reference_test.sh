#!/usr/bin/env bash
# The generated references in docs/reference/ are what the program prints now (tools/gen_reference
# writes them): a declaration changed without them fails here.
#   docs_reference_test.sh MINIMANIP_BINARY
set -u
cd "$(dirname "$0")/.."
bin="$1"
fail=0
for pair in config:config-doc nodes:nodes-doc results:results-doc gate:gate-doc; do
  file="docs/reference/${pair%%:*}.md" cmd="${pair#*:}"
  if ! diff -u <(tail -n +6 "$file") <("$bin" "$cmd") > /tmp/docs_reference_diff.$$ 2>&1; then
    echo "$file differs from \`minimanip $cmd\` (run tools/gen_reference and commit):"
    head -n 40 /tmp/docs_reference_diff.$$
    fail=1
  fi
done
rm -f /tmp/docs_reference_diff.$$
[ $fail -eq 0 ] && echo "references up to date"
exit $fail
