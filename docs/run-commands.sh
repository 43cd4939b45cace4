#!/usr/bin/env bash
# Runs every command of README.md and docs/guide/*.md in a fresh clone,
# in order, and stops at the first failure with its file and line.
#
#   docs/run-commands.sh CLONE_DIR
#
# The convention (docs/guide/README.md, "The commands in this guide"):
#   ```sh       blocks are run: cheap, no hardware, display, service or cluster;
#   ```console  blocks are shown, not run (a display, a device, liblsl, Slurm,
#               QEMU, or long); this script lists each one it skipped;
#   ```text     blocks are not commands.
# Each ```sh block runs in its own bash (set -eo pipefail), in CLONE_DIR,
# with `frictionlab` on PATH; background jobs a block leaves are killed
# when it ends. Files run in order: README.md, then docs/guide/*.md by name.
#
# FRICTIONLAB_BIN names a built frictionlab to use; otherwise the script
# runs `cargo build --release` in the clone (CARGO_TARGET_DIR is honoured).
#
# It also checks that .ci/run's test command is, byte for byte, a line of
# the README.
set -euo pipefail

if [ $# -ne 1 ] || [ ! -d "$1" ]; then
    echo "usage: $0 CLONE_DIR   (a fresh clone of the repository)" >&2
    exit 2
fi
clone=$(cd "$1" && pwd)
cd "$clone"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# frictionlab on PATH.
mkdir -p "$work/bin"
if [ -n "${FRICTIONLAB_BIN:-}" ]; then
    bin=$FRICTIONLAB_BIN
else
    echo "building frictionlab (cargo build --release) ..."
    cargo build --release --quiet
    bin="${CARGO_TARGET_DIR:-$clone/target}/release/frictionlab"
fi
[ -x "$bin" ] || { echo "error: no frictionlab binary at $bin" >&2; exit 2; }
ln -s "$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")" "$work/bin/frictionlab"
export PATH="$work/bin:$PATH"

# .ci/run's test command must be a line of the README.
ci_test=$(grep -E '^cargo test' .ci/run || true)
if [ -z "$ci_test" ] || ! grep -Fxq -- "$ci_test" README.md; then
    echo "FAILED: .ci/run's test command ('$ci_test') is not a line of README.md" >&2
    exit 1
fi
echo "ok: .ci/run's test command is the README's: $ci_test"

files=(README.md)
for f in docs/guide/*.md; do files+=("$f"); done

# Split the files into blocks: each ```sh block becomes a script
# $work/blocks/NNN.sh (with NNN.where: "file:line"), each ```console block
# a line of $work/skipped.
mkdir -p "$work/blocks"
: >"$work/skipped"
n=0
for f in "${files[@]}"; do
    n=$(awk -v file="$f" -v dir="$work/blocks" -v skipped="$work/skipped" -v n="$n" '
        function flush() { if (cmd != "") { print "__at " q file ":" cmdline q " " q esc(cmd) q > out; print cmd > out; cmd = "" } }
        function esc(s) { gsub(/\047/, "\047\\\047\047", s); return s }
        BEGIN { q = "\047"; inblock = 0 }
        /^```/ {
            if (!inblock) {
                lang = substr($0, 4); sub(/[ \t].*/, "", lang)
                inblock = 1; start = NR; first = ""
                if (lang == "sh") {
                    n++; out = sprintf("%s/%03d.sh", dir, n)
                    printf "%s:%d\n", file, NR > sprintf("%s/%03d.where", dir, n)
                    cmd = ""
                }
                next
            } else {
                if (lang == "sh") { flush(); close(out) }
                if (lang == "console") printf "%s:%d: %s\n", file, start, first >> skipped
                inblock = 0; next
            }
        }
        inblock && first == "" && $0 !~ /^[ \t]*$/ { first = $0 }
        inblock && lang == "sh" {
            if (cmd == "") { if ($0 ~ /^[ \t]*(#.*)?$/) next; cmdline = NR; cmd = $0 }
            else cmd = cmd "\n" $0
            if ($0 !~ /\\$/) flush()
        }
        END { print n }
    ' "$f")
done

ran=0
blocks=0
for script in "$work"/blocks/*.sh; do
    [ -e "$script" ] || continue
    where=$(cat "${script%.sh}.where")
    blocks=$((blocks + 1))
    count=$(grep -c '^__at ' "$script" || true)
    {
        cat <<'EOF'
set -eEo pipefail
__at() { __where=$1; printf '\n+ [%s] %s\n' "$1" "$2"; }
trap 'rc=$?; echo "FAILED: [$__where] exit $rc" >&2; exit $rc' ERR
trap 'rc=$?; trap - ERR; jobs -p | xargs -r kill 2>/dev/null || true; wait 2>/dev/null || true; exit $rc' EXIT
EOF
        cat "$script"
    } >"$script.run"
    echo
    echo "== block $blocks ($where): $count command(s)"
    if ! (cd "$clone" && bash "$script.run"); then
        echo
        echo "stopped at the first failure (block at $where); $ran command(s) ran before it" >&2
        exit 1
    fi
    ran=$((ran + count))
done

echo
echo "== skipped (\`\`\`console blocks, not run):"
sed 's/^/   /' "$work/skipped"
echo
echo "summary: $ran command(s) run in $blocks \`\`\`sh block(s) of ${#files[@]} file(s), all passed; $(wc -l <"$work/skipped") \`\`\`console block(s) skipped"
