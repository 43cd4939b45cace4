"""A pylsl inlet (the reference client) that records a frictionlab session's
two LSL streams for tests/lsl.rs.

    python inlet.py NAME OUT.json [--runs N] [--timeout S]

Resolves the marker stream (name NAME, type Markers) and the device stream
(name "NAME haptics", type Haptics), receives both until N session_end or
session_stop markers have come (a killed run sends none: the test says how
many runs end), then writes what came to OUT.json: every marker with its
timestamp, the device samples' count, first and last timestamps, whether
timestamps increased, the gaps (intervals over 1.5 sample periods: how many,
and their total beyond one period), the streams' info (source_id, nominal rate) and the
channels' label, unit and type read back from the description.
"""

import argparse
import json
import time

import pylsl


def channels(info):
    out = []
    ch = info.desc().child("channels").child("channel")
    while not ch.empty():
        out.append(
            {
                "label": ch.child_value("label"),
                "unit": ch.child_value("unit"),
                "type": ch.child_value("type"),
            }
        )
        ch = ch.next_sibling("channel")
    return out


def resolve(pred, timeout):
    found = pylsl.resolve_bypred(pred, 1, timeout)
    return found[0] if found else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("name")
    ap.add_argument("out")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=120.0)
    a = ap.parse_args()
    deadline = time.monotonic() + a.timeout
    info = None
    while info is None and time.monotonic() < deadline:
        info = resolve(f"name='{a.name}' and type='Markers'", 1.0)
    if info is None:
        raise SystemExit("no marker stream")
    # recover=True (pylsl's default): a killed outlet that comes back with
    # the same source_id is followed, as LabRecorder follows it.
    markers = pylsl.StreamInlet(info, max_buflen=360, recover=True)
    markers.open_stream(timeout=10.0)
    marker_info = markers.info(timeout=10.0)
    device = None
    device_info = None
    received = []
    count, first, last, increasing, prev = 0, None, None, True, None
    gaps, gap_s, period = 0, 0.0, None
    ticks = []
    ended = 0
    quiet_since = None
    next_resolve = 0.0
    while time.monotonic() < deadline:
        sample, ts = markers.pull_sample(timeout=0.01)
        while sample is not None:
            received.append([ts, sample[0]])
            event = json.loads(sample[0]).get("event")
            if event in ("session_end", "session_stop"):
                ended += 1
            sample, ts = markers.pull_sample(timeout=0.0)
        if device is None and time.monotonic() >= next_resolve:
            found = resolve(f"name='{a.name} haptics' and type='Haptics'", 0.2)
            next_resolve = time.monotonic() + 0.2
            if found is not None:
                device = pylsl.StreamInlet(found, max_buflen=360, recover=True)
                device.open_stream(timeout=10.0)
                device_info = device.info(timeout=10.0)
                period = 1.0 / device_info.nominal_srate()
        got = 0
        if device is not None:
            chunk, stamps = device.pull_chunk(timeout=0.0, max_samples=100000)
            got = len(stamps)
            for s, t in zip(chunk, stamps):
                if prev is not None and t <= prev:
                    increasing = False
                if prev is not None and t - prev > 1.5 * period:
                    gaps += 1
                    gap_s += t - prev - period
                prev = t
                if first is None:
                    first = t
                last = t
                count += 1
                if len(s) > 4:
                    ticks.append(s[4])
        if ended >= a.runs:
            if got == 0:
                quiet_since = quiet_since or time.monotonic()
                if time.monotonic() - quiet_since > 1.5:
                    break
            else:
                quiet_since = None
    ticks_consecutive = all(b - a == 1 for a, b in zip(ticks, ticks[1:]))
    ticks_increasing = all(b > a for a, b in zip(ticks, ticks[1:]))
    ticks_skipped = sum(int(b - a - 1) for a, b in zip(ticks, ticks[1:]) if b > a)
    out = {
        "markers": received,
        "marker_source_id": marker_info.source_id(),
        "marker_type": marker_info.type(),
        "marker_format": marker_info.channel_format(),
        "device": None
        if device_info is None
        else {
            "source_id": device_info.source_id(),
            "type": device_info.type(),
            "nominal_srate": device_info.nominal_srate(),
            "channel_count": device_info.channel_count(),
            "channels": channels(device_info),
            "model": device_info.desc().child("acquisition").child_value("model"),
            "mode": device_info.desc().child("rendering").child_value("mode"),
            "count": count,
            "first": first,
            "last": last,
            "increasing": increasing,
            "gaps": gaps,
            "gap_s": gap_s,
            "ticks_consecutive": ticks_consecutive,
            "ticks_increasing": ticks_increasing,
            "ticks_skipped": ticks_skipped,
            "ticks": len(ticks),
        },
    }
    with open(a.out, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
