#!/usr/bin/env bash
# Takes the screenshots in docs/screenshots/ of the experimenter window and
# the participant's screens, under a virtual X display (Xvfb), driving the
# windows with xdotool. Run from the repository root:
#
#   bash docs/screenshots.sh            # every picture
#   bash docs/screenshots.sh builder    # the setup and builder pictures only
#   bash docs/screenshots.sh results    # each kind's Results tab only
#   bash docs/screenshots.sh check      # the bring-up check only
#
# FRICTIONLAB_BIN names a frictionlab binary to use instead of building
# the release one; SCREENSHOT_DISPLAY the X display to use (default :97).
#
# Needs: xvfb, imagemagick, xdotool (installed here with apt-get if missing).
# Windows open at fixed places on a 1920x1080 screen (no window manager):
# the experimenter's at (0, 0), 1000x820; the participant's at (1010, 0),
# 900x560. The click positions below are in screen pixels.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v Xvfb >/dev/null || ! command -v xdotool >/dev/null || ! command -v import >/dev/null; then
    apt-get update -qq && apt-get install -y -qq xvfb imagemagick xdotool >/dev/null
fi
only="${1:-all}"
if [ -n "${FRICTIONLAB_BIN:-}" ]; then
    bin=$FRICTIONLAB_BIN
else
    cargo build --release --quiet
    bin="${CARGO_TARGET_DIR:-target}/release/frictionlab"
fi
out=docs/screenshots
work=$(mktemp -d)
export DISPLAY="${SCREENSHOT_DISPLAY:-:97}"
Xvfb "$DISPLAY" -screen 0 1920x1080x24 >/dev/null 2>&1 &
xvfb=$!
# The window (or session) the script last started, stopped by its pid.
app=""
stop() { if [ -n "$app" ]; then kill "$app" 2>/dev/null || true; wait "$app" 2>/dev/null || true; app=""; fi; }
trap 'stop; kill $xvfb 2>/dev/null || true; rm -rf "$work"' EXIT
sleep 1

shot() { import -window root -crop "$2" "$out/$1.png"; }
experimenter() { shot "$1" 1000x820+0+0; }
participant() { shot "$1" 900x560+1010+0; }
both() { shot "$1" 1910x820+0+0; }
click() { xdotool mousemove "$1" "$2" click 1; sleep "${3:-0.5}"; }
focus() { xdotool windowfocus --sync "$(xdotool search --name "frictionlab: participant" | head -1)"; }
type_text() { focus; xdotool type --delay 40 "$1"; sleep 0.3; }
session() { # protocol file [seed]; the window opens with its session started
    stop
    sleep 0.5
    "$bin" run "protocols/$1" --participant "shot-${2:-7}" --out "$work/results" --responder gui \
        --seed "${2:-7}" >>"$work/gui.log" 2>&1 &
    app=$!
    sleep 3
}
gui() { # results folder; the experimenter's window on it
    stop
    sleep 0.5
    "$bin" gui --participant p01 --out "$1" >>"$work/gui.log" 2>&1 &
    app=$!
    sleep 3
}
results_view() { # protocol file, kind, participants: that study simulated,
    # analysed from the Results tab, scrolled down to its figures
    local dir="$work/sim-$2"
    "$bin" simulate "protocols/$1" --participants "$3" --seed 1 --out "$dir" >>"$work/gui.log" 2>&1
    gui "$dir"
    click 177 52 1
    click 38 "$(( 134 + 23 * $(ls "$dir/logs" | wc -l) ))" 0.5
    for _ in $(seq 1 240); do [ -f "$dir/report/summary.json" ] && break; sleep 0.5; done
    sleep 2
    xdotool mousemove 500 600
    for _ in $(seq 1 "$4"); do xdotool click 5; sleep 0.05; done
    sleep 1
    experimenter "results-$2"
}
answer() { click 1282 142 0.2; focus; xdotool key ctrl+a BackSpace; type_text "$1"; xdotool key Return; sleep 0.4; }
stroke() { # the mouse drives the simulated hand back and forth
    for x in 1250 1700 1250 1700 1450; do xdotool mousemove "$x" 220; sleep 0.35; done
}

# The bring-up check in the Setup tab (issue 63), on an emulated 2DIY:
# a person's first prompt with its Done button (after the 10 s of loop
# timing), then, stopped, the whole check done by the simulated
# experimenter.
if [ "$only" = all ] || [ "$only" = check ]; then
    stop
    "$bin" device-emulator "haply2diy:$work/diy" >>"$work/gui.log" 2>&1 &
    emulated=$!
    sleep 1
    "$bin" gui --participant p01 --out "$work/results" --device "haply2diy:$work/diy" >>"$work/gui.log" 2>&1 &
    app=$!
    sleep 3
    click 146 322 12.5
    experimenter check-device-prompt
    click 58 305 1
    click 357 322 0.5
    click 146 322 22
    experimenter check-device
    stop
    kill "$emulated" 2>/dev/null || true
    wait "$emulated" 2>/dev/null || true
fi
if [ "$only" = check ]; then exit 0; fi

# Each kind's view in the Results tab (issue 45): a simulated study of its
# shipped protocol, analysed from the window, its sentences and figures.
if [ "$only" = all ] || [ "$only" = results ]; then
    results_view paired-comparison.json paired_comparison 8 0
    results_view magnitude-estimation.json magnitude_estimation 8 1
    results_view fitts.json fitts 8 4
    results_view discrimination.json discrimination 8 1
fi
if [ "$only" = results ]; then exit 0; fi

# The experimenter's setup.
gui "$work/results"
experimenter experimenter-setup

# The protocol builder: a shipped protocol as forms; then a new paired
# comparison with an invalid exploration time (the check's message under
# the field, Save refused), fixed, and its first condition felt on the
# simulated device with the pointer stroking the strip.
click 290 52 1
experimenter experimenter-builder
click 463 85 1
click 185 475 0.3
xdotool windowfocus --sync "$(xdotool search --name "frictionlab: experimenter" | head -1)"
xdotool key ctrl+a; xdotool type --delay 60 -- "-3"; sleep 0.8
experimenter experimenter-builder-invalid
xdotool key ctrl+a; xdotool type --delay 60 -- "10"; sleep 0.5
click 330 167 1
for x in 300 700 400 650; do xdotool mousemove "$x" 225; sleep 0.3; done
experimenter experimenter-builder-feel
if [ "$only" = builder ]; then exit 0; fi

# Magnitude estimation: instructions, exploring, a refused entry.
session magnitude-quick.json
participant participant-instructions
click 1081 111 0.3
stroke
both session-magnitude
sleep 1
click 1282 142 0.3
type_text "abc"
click 1480 144
participant participant-magnitude-refused

# The rest of the session: three answers, the break between the blocks,
# three more, the end.
answer 2.5
answer 3
answer 4
participant participant-break
click 1081 111
answer 1; answer 2; answer 3
participant participant-finished

# Paired comparison: the reference phase, then the two stimuli.
session paired-quick.json
click 1081 111
participant participant-reference
click 1081 111
stroke
click 1312 95
participant participant-paired

# Discrimination: the two intervals and the protocol's question, then ten
# answers ("stimulus 2") and the experimenter's live plot of the tracks.
session discrimination-quick.json
click 1081 111
stroke
click 1312 95
participant participant-discrimination
for _ in $(seq 1 9); do click 1239 185 0.5; done
click 1239 185 1.5
both session-discrimination-tracks

# Fitts (seed 2: the `real` condition follows the practice trial): a miss,
# four hits, then the experimenter's prompt to attach the block.
session fitts-quick.json 2
click 1081 111
xdotool mousemove 1318 193; sleep 0.6; click 1318 193
participant participant-fitts-miss
for x in 1283 1637 1283 1637; do xdotool mousemove "$x" 193; sleep 0.6; click "$x" 193 0.2; done
sleep 0.5
both session-fitts-prompt

# The Results tab over this script's results folder: every session and its
# status, then the analysis the Analyze button runs.
gui "$work/results"
click 177 52 1
experimenter experimenter-results
click 38 "$(( 134 + 23 * $(ls "$work/results/logs" | wc -l) ))" 6
experimenter experimenter-results-analysis

# Frame time with a live session on the simulated device: 30 s of the full
# magnitude-estimation protocol with the mouse stroking, then Ctrl+Q (the
# window prints its frame-time statistics on exit).
session magnitude-estimation.json
click 1081 111
for _ in $(seq 1 12); do stroke; done
xdotool windowfocus --sync "$(xdotool search --name "frictionlab: experimenter" | head -1)"
xdotool key ctrl+q
sleep 1
grep "frame time" "$work/gui.log" | tail -1
