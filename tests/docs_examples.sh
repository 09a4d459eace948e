#!/usr/bin/env bash
# Runs every scene example of docs/scene-language.md: ```scad blocks must pass check-scene and mesh;
# ```scad-error MESSAGE blocks must fail (exit 1) with MESSAGE in the error text.
# Usage: docs_examples.sh ISOFORGE SOURCE_DIR
set -u
bin=$(realpath "$1")
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Examples name files relative to the repository root: run them from a directory that has its data/.
ln -s "$src/data" "$tmp/data"
ln -s "$src/examples" "$tmp/examples"
awk -v dir="$tmp" '
    /^```scad/ { n++; inside = 1; expect = ""; if ($0 ~ /^```scad-error /) { expect = substr($0, 15) }
                 file = sprintf("%s/example%02d.isf", dir, n); printf "" > file;
                 if (expect != "") { print expect > (file ".expect") } next }
    /^```/ && inside { inside = 0; close(file); next }
    inside { print >> file }
' "$src/docs/scene-language.md"
count=$(ls "$tmp"/example*.isf 2>/dev/null | wc -l)
if [ "$count" -lt 10 ]; then echo "FAIL: found only $count examples"; exit 1; fi
fail=0
cd "$tmp"
for f in example*.isf; do
    if [ -f "$f.expect" ]; then
        want=$(cat "$f.expect")
        out=$("$bin" check-scene "$f" 2>&1); rc=$?
        if [ $rc -ne 1 ] || ! grep -qF -- "${want}" <<<"$out"; then
            echo "FAIL: $f should fail with '$want' (rc $rc):"; cat "$f"; echo "$out"; fail=1
        fi
        continue
    fi
    if ! out=$("$bin" --quiet check-scene "$f" 2>&1); then echo "FAIL: check-scene $f:"; cat "$f"; echo "$out"; fail=1; continue; fi
    if ! out=$("$bin" --quiet mesh "$f" --resolution 64 -o "$f.ply" 2>&1) || [ ! -s "$f.ply" ]; then
        echo "FAIL: mesh $f:"; cat "$f"; echo "$out"; fail=1; continue
    fi
    if ! out=$("$bin" check "$f.ply" --strict 2>&1); then echo "FAIL: $f.ply is not a closed manifold:"; cat "$f"; echo "$out"; fail=1; fi
done
[ $fail -eq 0 ] && echo "all $count examples of docs/scene-language.md pass"
exit $fail
