#!/usr/bin/env bash
# Regenerates every study reproduction in analysis/: a simulated replay of
# the shipped protocol with the study's number of participants, then its
# analysis (summary.json, report.html, tables/); the robustness replays
# over the simulated participant's free constants (robustness/<point>/:
# the population file and each study's summary.json); and claims.md, the
# claims table generated from all of them. tests/analysis_sync.rs checks
# that the committed files match a fresh run.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --quiet --release
bin="${CARGO_TARGET_DIR:-target}/release/frictionlab"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# study participants seed
main_studies='paired-comparison 6 2000
magnitude-estimation 10 2001
fitts 20 2002'

while read -r study participants seed; do
  "$bin" simulate "protocols/$study.json" --participants "$participants" --seed "$seed" --out "$tmp/$study/results" >/dev/null
  rm -rf "analysis/$study"
  "$bin" analyze "$tmp/$study/results" --out "analysis/$study" >/dev/null
done <<<"$main_studies"

# replay POINT POPULATION_JSON STUDY...: the studies with that population
# (paired comparison with 60 participants: 6 cannot tell a rate).
replay() {
  local point=$1 population=$2
  shift 2
  local out="analysis/robustness/$point"
  mkdir -p "$out"
  printf '%s\n' "$population" >"$out/population.json"
  for study in "$@"; do
    local participants seed
    read -r _ participants seed < <(grep "^$study " <<<"$main_studies")
    [ "$study" = paired-comparison ] && participants=60
    rm -rf "$tmp/results"
    "$bin" simulate "protocols/$study.json" --participants "$participants" --seed "$seed" \
      --population "$out/population.json" --out "$tmp/results" >/dev/null
    "$bin" analyze "$tmp/results" --out "$tmp/a" >/dev/null
    cp "$tmp/a/summary.json" "$out/$study.json"
    rm -rf "$tmp/a"
  done
}

rm -rf analysis/robustness
all='paired-comparison magnitude-estimation fitts'
replay default '{}' $all
replay hand-impedance-low '{"hand_stiffness_n_m": [100, 400], "hand_damping_n_s_m": [5, 20]}' $all
replay hand-impedance-high '{"hand_stiffness_n_m": [400, 1600], "hand_damping_n_s_m": [20, 80]}' $all
replay motor-noise-low '{"motor_noise_s": [0.005, 0.01]}' $all
replay motor-noise-high '{"motor_noise_s": [0.02, 0.04]}' $all
replay perceptual-noise-low '{"position_sd_m": [5e-5, 1.5e-4], "force_weber": [0.035, 0.075], "vibration_weber": [0.075, 0.15], "displacement_weber": [0.05, 0.09], "velocity_weber": [0.06, 0.12]}' $all
replay perceptual-noise-high '{"position_sd_m": [2e-4, 6e-4], "force_weber": [0.14, 0.3], "vibration_weber": [0.3, 0.6], "displacement_weber": [0.2, 0.36], "velocity_weber": [0.24, 0.48]}' $all
replay breakaway-weight-0 '{"breakaway_weight": 0.0}' magnitude-estimation
replay breakaway-weight-1 '{"breakaway_weight": 1.0}' magnitude-estimation
replay tactile-gain-0.01 '{"tactile_gain_n": 0.01}' magnitude-estimation
replay tactile-gain-1 '{"tactile_gain_n": 1.0}' magnitude-estimation
replay desk-mu-0.4 '{"desk_mu": 0.4}' paired-comparison
replay desk-mu-0.8 '{"desk_mu": 0.8}' paired-comparison
for k in 150 300 600 1000; do
  for b in 5 10 20 40; do
    replay "hand-k$k-b$b" "{\"hand_stiffness_n_m\": [$k, $k], \"hand_damping_n_s_m\": [$b, $b]}" paired-comparison
  done
done

"$bin" claims analysis --fitts-protocol protocols/fitts.json

# The validation table: the protocols in analysis/validation/ (each with
# its published result and band) replayed with simulated participants, and
# the sweep over the population's constants (validation.md, validation.json).
"$bin" validation analysis
