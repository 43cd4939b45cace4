#!/usr/bin/env bash
# Regenerates every study reproduction in analysis/: a simulated replay of
# the shipped protocol with the study's number of participants, then its
# analysis (summary.json, report.html, tables/). tests/analysis_sync.rs
# checks that the committed summaries match a fresh replay.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet --release
bin=target/release/frictionlab
while read -r study participants seed; do
  tmp=$(mktemp -d)
  "$bin" simulate "protocols/$study.json" --participants "$participants" --seed "$seed" --out "$tmp/results"
  rm -rf "analysis/$study"
  "$bin" analyze "$tmp/results" --out "analysis/$study"
  rm -rf "$tmp"
done <<'STUDIES'
paired-comparison 6 2000
magnitude-estimation 10 2001
fitts 20 2002
STUDIES
