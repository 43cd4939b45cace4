"""LabRecorder, started before a session, records it to XDF (issue 42).

Usage: record.py NAME OUT.json --xdf FILE.xdf --ready FILE --stop FILE
                 [--timeout S]

Starts LabRecorder's own recording code (the `labrecorder` bindings from
PyPI) before the session's streams exist, watching for the marker stream
`NAME` and the device stream `NAME haptics` as LabRecorder's watch list
does: it looks for missing streams every 5 s and records each from when it
finds it. Touches READY once recording, stops once STOP exists (or after
the timeout), lets the recorder write the file (it writes on deletion),
reads the XDF back with pyxdf (raw timestamps, no clock synchronisation)
and writes OUT.json:

    {"markers": [[timestamp, text], ...],
     "device": {"count": N, "first": t, "last": t, "channels": C} | null}
"""

import argparse
import gc
import json
import os
import time

import labrecorder
import pyxdf


def main():
    p = argparse.ArgumentParser()
    p.add_argument("name")
    p.add_argument("out")
    p.add_argument("--xdf", required=True)
    p.add_argument("--ready", required=True)
    p.add_argument("--stop", required=True)
    p.add_argument("--timeout", type=float, default=240.0)
    a = p.parse_args()

    watch = [f"name='{a.name}'", f"name='{a.name} haptics'"]
    recording = labrecorder.Recording(a.xdf, [], watch)
    open(a.ready, "w").close()
    deadline = time.monotonic() + a.timeout
    while not os.path.exists(a.stop) and time.monotonic() < deadline:
        time.sleep(0.05)
    recording.stop()
    # The bindings write the file when the recording object goes.
    del recording
    gc.collect()
    for _ in range(200):
        if os.path.exists(a.xdf) and os.path.getsize(a.xdf) > 0:
            break
        time.sleep(0.1)
    streams, _ = pyxdf.load_xdf(a.xdf, synchronize_clocks=False, dejitter_timestamps=False)
    out = {"markers": [], "device": None}
    for s in streams:
        info = s["info"]
        kind = info["type"][0]
        stamps = [float(t) for t in s["time_stamps"]]
        if kind == "Markers":
            out["markers"] = [[t, v[0]] for t, v in zip(stamps, s["time_series"])]
        elif kind == "Haptics":
            out["device"] = {
                "count": len(stamps),
                "first": stamps[0] if stamps else None,
                "last": stamps[-1] if stamps else None,
                "channels": int(info["channel_count"][0]),
                "increasing": all(b > a for a, b in zip(stamps, stamps[1:])),
            }
    with open(a.out, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
